//! Hello binding, one rule for the world and every host: a robot's process is bound to the
//! publisher its hello came from, later samples are attributed by that origin (never by the
//! id a robot writes into them), and only a hello takes a robot's waiting slot.

use std::collections::{BTreeMap, BTreeSet};

use swarmrt_protocol::{Command, CommandKind, PROTOCOL_VERSION};

/// What one command sample is, by its origin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sample {
    /// From the bound process of this robot: its answer (or an extra sample).
    Robot(u32),
    /// A hello that bound its origin to this robot, which waited for it.
    Hello(u32),
    /// A hello from an unbound origin for a robot that waits for none (a taken or unknown
    /// id): ignored.
    BadHello,
    /// Anything else from an unbound origin: ignored.
    Unknown,
}

/// True when `c` is a hello of this protocol version.
pub fn is_hello(c: &Command) -> bool {
    c.version == PROTOCOL_VERSION && CommandKind::from_u32(c.kind) == Some(CommandKind::Hello)
}

/// Which origin speaks for which robot, and which robots wait for a hello. `K` is the
/// origin: an iceoryx2 publisher, or a remote host's robot.
#[derive(Debug, Clone)]
pub struct Bindings<K> {
    robot_of: BTreeMap<K, u32>,
    origin_of: BTreeMap<u32, K>,
    awaiting: BTreeSet<u32>,
}

impl<K: Ord + Clone> Bindings<K> {
    /// Nothing bound; `robots` wait for their first hello.
    pub fn awaiting(robots: impl IntoIterator<Item = u32>) -> Bindings<K> {
        Bindings {
            robot_of: BTreeMap::new(),
            origin_of: BTreeMap::new(),
            awaiting: robots.into_iter().collect(),
        }
    }

    /// Classifies a sample from `origin`, binding it on a hello the robot waits for.
    pub fn accept(&mut self, origin: K, c: &Command) -> Sample {
        self.accept_claiming(origin, c, |_| true)
    }

    /// [`Self::accept`], where an unbound origin may claim only robots `may_claim` allows
    /// (a remote host's entry only the robot it is attributed to; a local publisher no robot
    /// of a remote host).
    pub fn accept_claiming(
        &mut self,
        origin: K,
        c: &Command,
        may_claim: impl FnOnce(u32) -> bool,
    ) -> Sample {
        if let Some(&robot) = self.robot_of.get(&origin) {
            return Sample::Robot(robot);
        }
        if !is_hello(c) {
            return Sample::Unknown;
        }
        if !may_claim(c.robot) || !self.awaiting.remove(&c.robot) {
            return Sample::BadHello;
        }
        self.robot_of.insert(origin.clone(), c.robot);
        self.origin_of.insert(c.robot, origin);
        Sample::Hello(c.robot)
    }

    fn unbind(&mut self, robot: u32) {
        if let Some(origin) = self.origin_of.remove(&robot) {
            self.robot_of.remove(&origin);
        }
    }

    /// A restart: samples from the old process are no robot's any more, and the fresh
    /// process's hello is awaited.
    pub fn expect_hello(&mut self, robot: u32) {
        self.unbind(robot);
        self.awaiting.insert(robot);
    }

    /// A kill, a death or an unresponsive robot: unbound, and no hello awaited.
    pub fn forget(&mut self, robot: u32) {
        self.unbind(robot);
        self.awaiting.remove(&robot);
    }

    /// True while `robot` waits for a hello.
    pub fn is_awaiting(&self, robot: u32) -> bool {
        self.awaiting.contains(&robot)
    }

    /// The robots that wait for a hello.
    pub fn awaiting_set(&self) -> &BTreeSet<u32> {
        &self.awaiting
    }

    /// True when some process speaks for `robot`.
    pub fn is_bound(&self, robot: u32) -> bool {
        self.origin_of.contains_key(&robot)
    }
}
