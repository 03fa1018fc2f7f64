//! How the processes of a run meet over iceoryx2: the per-run iceoryx2 config and the two
//! service pairs of DESIGN section 2, created by the world and opened by robots. The messages
//! themselves are plain `#[repr(C)]` types in `swarmrt-protocol`, which the cores use without
//! linking iceoryx2.
//!
//! Topology (flat in N, see DESIGN section 9): one observation service whose samples hold
//! every robot's slot, command services that robots publish on in groups of
//! [`COMMAND_GROUP`] ids (one group per service keeps the world's drain O(N), see
//! [`CommandSubscribers`]), and an event service beside each side to wake the other. Both pub/sub services keep iceoryx2's safe overflow on: in
//! lock-step no queue ever holds more than one sample per publisher, so overflow cannot drop
//! anything, and a publisher never blocks on a subscriber that was SIGKILLed.

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2_bb_system_types::file_name::FileName;
use iceoryx2_bb_system_types::path::Path as IoxPath;

pub use swarmrt_protocol::services::COMMAND_GROUP;
use swarmrt_protocol::services::{EVENT_COMMAND, EVENT_CONTROL, RunServices, command_group_of};
use swarmrt_protocol::{Command, Observation, ObservationHeader, PROTOCOL_VERSION};

pub mod bell;
pub mod cleanup;
pub mod lines;
pub mod mgmt_segment;
pub mod rounds;

/// Shortcut for the iceoryx2 service flavour every process uses.
pub type Svc = ipc::Service;

/// Error type of this module (iceoryx2 errors are many distinct types).
pub type IpcError = Box<dyn std::error::Error + Send + Sync>;

/// Per-run iceoryx2 config: own root directory and shared-memory prefix (isolation and
/// exact cleanup), and no dead-node scan on every node creation (it made 200 robots take ~10 s
/// to start; the orchestrator cleans a run's resources itself).
pub fn ipc_config(run: &RunServices) -> Result<Config, IpcError> {
    let mut cfg = Config::default();
    let root = format!("{}/", run.ipc_root().display());
    cfg.global.set_root_path(
        &IoxPath::new(root.as_bytes()).map_err(|e| format!("ipc root {root}: {e:?}"))?,
    );
    cfg.global.prefix =
        FileName::new(run.shm_prefix().as_bytes()).map_err(|e| format!("ipc prefix: {e:?}"))?;
    cfg.global.node.cleanup_dead_nodes_on_creation = false;
    cfg.global.node.cleanup_dead_nodes_on_destruction = false;
    cfg.global.service.cleanup_dead_nodes_on_open = false;
    // Robots open services the world created moments before; allow a slow machine time.
    cfg.global.creation_timeout = core::time::Duration::from_secs(10);
    Ok(cfg)
}

/// The run's iceoryx2 config as the text of an `iceoryx2.toml` (what [`write_config_file`]
/// writes), for a writer that holds its directory's handle.
pub fn config_file_text(run: &RunServices) -> Result<String, IpcError> {
    Ok(toml::to_string(&ipc_config(run)?)?)
}

/// Writes the run's iceoryx2 config as an `iceoryx2.toml` at `path`: iceoryx2's own tools
/// (`iox2 service list`, `hz`, `subscribe`, `record`) read `config/iceoryx2.toml` from their
/// working directory, and a robot in another language loads it as its node's config.
pub fn write_config_file(run: &RunServices, path: &std::path::Path) -> Result<(), IpcError> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let text = config_file_text(run)?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
        // The file and the directory it is in are never links (docs/security.md).
        if std::fs::symlink_metadata(dir)?.file_type().is_symlink() {
            return Err(std::io::Error::other(format!(
                "{} is a symbolic link; refusing to follow it",
                dir.display()
            ))
            .into());
        }
    }
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .custom_flags(libc::O_NOFOLLOW)
        .open(path)
        .map_err(|e| {
            if e.raw_os_error() == Some(libc::ELOOP) {
                std::io::Error::other(format!(
                    "{} is a symbolic link; refusing to follow it",
                    path.display()
                ))
            } else {
                e
            }
        })?;
    file.write_all(text.as_bytes())?;
    Ok(())
}

/// Raises this process's soft open-file limit to its hard limit. The world holds about five
/// descriptors per robot (the robot's command segment and connection, its observation
/// connection, its event socket), which passes the common soft limit of 1,024 near 200
/// robots. Returns the new soft limit.
pub fn raise_fd_limit() -> std::io::Result<u64> {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit/setrlimit only read and write the struct we pass.
    if unsafe { libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    if lim.rlim_cur < lim.rlim_max {
        lim.rlim_cur = lim.rlim_max;
        if unsafe { libc::setrlimit(libc::RLIMIT_NOFILE, &lim) } != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(lim.rlim_cur)
}

/// Creates a node named `name` with the run's config, and makes SIGINT and SIGTERM stick
/// for [`termination_requested`]. The run's management segment is checked first (made
/// private if missing, refused in one line if another user could have touched it:
/// [`mgmt_segment`]), so the node never waits on a segment it cannot trust.
pub fn node(run: &RunServices, name: &str) -> Result<Node<Svc>, IpcError> {
    let cfg = ipc_config(run)?;
    mgmt_segment::ensure(&cfg)?;
    let name = NodeName::new(name).map_err(|e| format!("node name {name}: {e:?}"))?;
    let node = NodeBuilder::new()
        .name(&name)
        .config(&cfg)
        .create::<Svc>()?;
    note_termination_signals();
    Ok(node)
}

/// Set by [`on_termination_signal`]; never cleared.
static TERMINATION: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

extern "C" fn on_termination_signal(_: libc::c_int) {
    TERMINATION.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// Routes SIGINT and SIGTERM to a flag of our own. iceoryx2's handler keeps only the *last*
/// signal, so the SIGCONT the orchestrator sends right after SIGTERM (a stopped process acts on
/// SIGTERM only once continued) erased the request and the robot sat out its grace period
/// until SIGKILL (`crashes::ctrl_c_during_start_up...`, 1 run in 12 under load). No
/// `SA_RESTART`, like iceoryx2: a listener's wait still ends with `EINTR` on these signals.
pub fn note_termination_signals() {
    use iceoryx2_bb_posix::signal::SignalHandler;
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        // The first call installs iceoryx2's handlers (ours must come after them to win) and
        // returns what they caught so far; the second, what arrived before ours took over.
        let before = SignalHandler::termination_requested();
        for signal in [libc::SIGINT, libc::SIGTERM] {
            // SAFETY: a zeroed sigaction with an empty mask and a handler that only stores an
            // atomic, which is async-signal-safe.
            unsafe {
                let mut action: libc::sigaction = std::mem::zeroed();
                action.sa_sigaction = on_termination_signal as *const () as libc::sighandler_t;
                libc::sigemptyset(&mut action.sa_mask);
                libc::sigaction(signal, &action, std::ptr::null_mut());
            }
        }
        if before || SignalHandler::termination_requested() {
            TERMINATION.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    });
}

/// True once SIGINT or SIGTERM reached this process, for a node that handles termination
/// requests: the check [`Node::wait`] makes, without its `nanosleep` (a zero-length sleep is
/// still a syscall, which every robot paid once a tick: ~4 % of a goto robot's CPU at 100
/// robots, by perf). Sticky: a later signal (SIGCONT, SIGCHLD) does not undo it.
pub fn termination_requested(node: &Node<Svc>) -> bool {
    node.signal_handling_mode() == SignalHandlingMode::HandleTerminationRequests
        && TERMINATION.load(std::sync::atomic::Ordering::Relaxed)
}

fn service_name(s: &str) -> Result<ServiceName, IpcError> {
    Ok(ServiceName::new(s).map_err(|e| format!("service name {s}: {e:?}"))?)
}

/// The observation service handle.
pub type ObservationService = iceoryx2::service::port_factory::publish_subscribe::PortFactory<
    Svc,
    [Observation],
    ObservationHeader,
>;
/// The command service handle.
pub type CommandService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, Command, ()>;
/// An event service handle.
pub type EventService = iceoryx2::service::port_factory::event::PortFactory<Svc>;

/// Observation samples the world's publisher preallocates. iceoryx2's worst case is about
/// subscribers x (buffer + borrowed), i.e. ~2N samples of ~6 KB x N each: over 1 GB of shared
/// memory at 200 robots. In lock-step at most one sample is queued or held per robot, and
/// the world reclaims a dead robot's samples by cleaning up its node, so a few suffice.
pub const OBSERVATION_SAMPLES: usize = 16;

/// Services of a run, as the world creates them (sized from the robot count).
pub struct WorldServices {
    /// World -> robots samples.
    pub observations: ObservationService,
    /// World -> robots wake-up.
    pub observations_event: EventService,
    /// Robots -> world samples: one service per group of [`COMMAND_GROUP`] robot ids, from
    /// the group of the first robot id on.
    pub commands: Vec<CommandService>,
    /// Robots (and the world's control thread) -> world wake-up.
    pub commands_event: EventService,
    /// World -> robots wake-up in one call ([`bell`]): robots of this build sleep on it; the
    /// event above still wakes observers and robots in other languages that listen on it.
    pub bell: std::sync::Arc<bell::Bell>,
}

/// Creates the run's services for the robots of ids `robots` (a host's robots start at its
/// first id). Extra ports leave room for the world's control thread and for the fresh
/// processes of up to `restarts` restarted robots whose old ports are not yet reclaimed;
/// `observers` spare subscriber and listener slots (and nodes) let a tool, recorder or
/// viewer attach read-only mid-run (`ipc.observers`).
pub fn create_services(
    node: &Node<Svc>,
    run: &RunServices,
    robots: std::ops::Range<u32>,
    restarts: usize,
    observers: usize,
) -> Result<WorldServices, IpcError> {
    let n = robots.len() + 8 + restarts;
    let o = observers;
    let observations = node
        .service_builder(&service_name(&run.observations())?)
        .publish_subscribe::<[Observation]>()
        .user_header::<ObservationHeader>()
        .max_publishers(1)
        .max_subscribers(n + o)
        .max_nodes(n + 2 + o)
        .subscriber_max_buffer_size(1)
        .subscriber_max_borrowed_samples(1)
        .history_size(0)
        .enable_safe_overflow(true)
        .create()?;
    let observations_event = node
        .service_builder(&service_name(&run.observations())?)
        .event()
        .max_notifiers(2)
        .max_listeners(n + o)
        .max_nodes(n + 2 + o)
        .create()?;
    let groups = command_groups(&robots);
    let per_group = (COMMAND_GROUP as usize).min(robots.len()) + 8 + restarts;
    let commands = groups
        .map(|g| {
            Ok(node
                .service_builder(&service_name(&run.command_group(g))?)
                .publish_subscribe::<Command>()
                .max_publishers(per_group)
                .max_subscribers(1 + o)
                .max_nodes(per_group + 2 + o)
                .subscriber_max_buffer_size(2)
                .subscriber_max_borrowed_samples(1)
                .history_size(0)
                .enable_safe_overflow(true)
                .create()?)
        })
        .collect::<Result<Vec<_>, IpcError>>()?;
    let commands_event = node
        .service_builder(&service_name(&run.commands())?)
        .event()
        .max_notifiers(n + 2)
        .max_listeners(2 + o)
        .max_nodes(n + 2 + o)
        .create()?;
    let bell = bell::Bell::create(run).map_err(|e| {
        format!(
            "cannot create the tick bell {}: {e}",
            bell::path(run).display()
        )
    })?;
    Ok(WorldServices {
        observations,
        observations_event,
        commands,
        commands_event,
        bell: std::sync::Arc::new(bell),
    })
}

/// The command service groups that hold the robots of ids `robots` (none for no robots).
pub fn command_groups(robots: &std::ops::Range<u32>) -> std::ops::Range<u32> {
    if robots.is_empty() {
        return 0..0;
    }
    command_group_of(robots.start)..command_group_of(robots.end - 1) + 1
}

/// The services as a robot opens them.
pub struct RobotServices {
    /// World -> robots samples.
    pub observations: ObservationService,
    /// World -> robots wake-up.
    pub observations_event: EventService,
    /// This robot's command group.
    pub commands: CommandService,
    /// Robots -> world wake-up.
    pub commands_event: EventService,
}

/// Opens the services the world created, as robot `id` uses them.
pub fn open_services(
    node: &Node<Svc>,
    run: &RunServices,
    id: u32,
) -> Result<RobotServices, IpcError> {
    Ok(RobotServices {
        observations: node
            .service_builder(&service_name(&run.observations())?)
            .publish_subscribe::<[Observation]>()
            .user_header::<ObservationHeader>()
            .open()?,
        observations_event: node
            .service_builder(&service_name(&run.observations())?)
            .event()
            .open()?,
        commands: node
            .service_builder(&service_name(&run.robot_commands(id))?)
            .publish_subscribe::<Command>()
            .open()?,
        commands_event: node
            .service_builder(&service_name(&run.commands())?)
            .event()
            .open()?,
    })
}

/// Opens only the command event service (the world's control thread uses it to wake the
/// world's main loop).
pub fn open_commands_event(node: &Node<Svc>, run: &RunServices) -> Result<EventService, IpcError> {
    Ok(node
        .service_builder(&service_name(&run.commands())?)
        .event()
        .open()?)
}

/// The world's four ports: observations out (and their wake-up), commands in (and theirs).
pub struct WorldPorts {
    /// Publishes one sample per tick holding every robot's observation.
    pub publisher: Publisher<Svc, [Observation], ObservationHeader>,
    /// Wakes the robots after a publish.
    pub notifier: Notifier<Svc>,
    /// Commands from every robot.
    pub commands: CommandSubscribers,
    /// Woken by the robots (and the world's control thread).
    pub listener: Listener<Svc>,
    /// Wakes every robot of this build at once.
    pub bell: std::sync::Arc<bell::Bell>,
}

impl WorldPorts {
    /// Opens the world's ports on the run's services (as created by [`create_services`]),
    /// for `slots` robots and `observers` read-only subscribers (each may hold two samples:
    /// one queued, one borrowed).
    pub fn open(
        services: &WorldServices,
        slots: usize,
        observers: usize,
    ) -> Result<WorldPorts, IpcError> {
        let WorldServices {
            observations,
            observations_event,
            commands,
            commands_event,
            bell,
        } = services;
        Ok(WorldPorts {
            bell: bell.clone(),
            publisher: observations
                .publisher_builder()
                .initial_max_slice_len(slots)
                .override_sample_preallocation(move |_| OBSERVATION_SAMPLES + 2 * observers)
                .create()?,
            notifier: observations_event.notifier_builder().create()?,
            commands: CommandSubscribers::open(commands)?,
            listener: commands_event.listener_builder().create()?,
        })
    }

    /// Publishes the tick's observation slots, one sample for every robot of this host, and
    /// wakes the robots: the one way a world or a host hands out a tick.
    pub fn publish(&self, tick: u64, slots: &[Observation]) -> Result<(), IpcError> {
        self.send(tick, false, slots)
    }

    /// Publishes the header-only sample that tells every robot the run is over, and wakes them.
    pub fn publish_shutdown(&self, tick: u64) -> Result<(), IpcError> {
        self.send(tick, true, &[])
    }

    fn send(&self, tick: u64, shutdown: bool, slots: &[Observation]) -> Result<(), IpcError> {
        let sample = self.publisher.loan_slice_uninit(slots.len())?;
        let mut sample = sample.write_from_slice(slots);
        *sample.user_header_mut() = ObservationHeader {
            version: PROTOCOL_VERSION,
            shutdown: u32::from(shutdown),
            tick,
        };
        sample.send()?;
        self.wake_robots()
    }

    /// Wakes the robots after a sample was sent: every robot sleeping on the bell with one
    /// call, and the listeners of the observation event (observers, robots in other
    /// languages that listen), one notification each.
    pub fn wake_robots(&self) -> Result<(), IpcError> {
        self.bell.ring()?;
        self.notifier.notify()?;
        Ok(())
    }
}

/// The world's subscribers of the command groups, drained one group after the other.
pub struct CommandSubscribers {
    groups: Vec<Subscriber<Svc, Command, ()>>,
    /// The group [`CommandSubscribers::receive`] looks in first.
    next: std::cell::Cell<usize>,
}

/// A command as received from a group.
pub type CommandSample = iceoryx2::sample::Sample<Svc, Command, ()>;

impl CommandSubscribers {
    /// One subscriber per group service.
    pub fn open(groups: &[CommandService]) -> Result<CommandSubscribers, IpcError> {
        Ok(CommandSubscribers {
            groups: groups
                .iter()
                .map(|g| g.subscriber_builder().create())
                .collect::<Result<_, _>>()?,
            next: std::cell::Cell::new(0),
        })
    }

    /// The next command of any group; `None` once every group was found empty in turn, so
    /// `while let Some(c) = commands.receive()?` drains them all. A group is left only when
    /// it is empty: iceoryx2 walks a group's publishers per sample, so this is O(group) each.
    pub fn receive(&self) -> Result<Option<CommandSample>, IpcError> {
        while let Some(group) = self.groups.get(self.next.get()) {
            if let Some(sample) = group.receive()? {
                return Ok(Some(sample));
            }
            self.next.set(self.next.get() + 1);
        }
        self.next.set(0);
        Ok(None)
    }
}

/// How a robot sleeps until the world publishes.
pub enum TickWait {
    /// On the run's bell: the world wakes all such robots with one call.
    Bell(bell::Bell),
    /// In a listener of the observation event: one notification per robot per tick (the
    /// benchmarks' floor, and what robots in other languages may still do).
    Listener(Box<Listener<Svc>>),
}

impl TickWait {
    /// What to pass to [`TickWait::wait`]: read it before looking for samples.
    pub fn seen(&self) -> u32 {
        match self {
            TickWait::Bell(b) => b.seen(),
            TickWait::Listener(_) => 0,
        }
    }

    /// Sleeps until the world wakes the robots after `seen`, for at most `timeout`.
    pub fn wait(&self, seen: u32, timeout: std::time::Duration) -> Result<bell::Woke, IpcError> {
        use iceoryx2::port::listener::ListenerWaitError;
        match self {
            TickWait::Bell(b) => Ok(b.wait(seen, timeout)?),
            TickWait::Listener(l) => match l.timed_wait(|_| {}, timeout) {
                Ok(0) => Ok(bell::Woke::TimedOut),
                Ok(_) => Ok(bell::Woke::Rung),
                Err(ListenerWaitError::InterruptSignal) => Ok(bell::Woke::Interrupted),
                Err(e) => Err(e.into()),
            },
        }
    }
}

/// A robot's four ports: observations in (and their wake-up), its commands out (and theirs).
pub struct RobotPorts {
    /// Every robot's observations; a robot reads its own slot.
    pub subscriber: Subscriber<Svc, [Observation], ObservationHeader>,
    /// Woken by the world after each publish.
    pub wait: TickWait,
    /// This robot's commands.
    pub publisher: Publisher<Svc, Command, ()>,
    /// Wakes the world after each command.
    pub notifier: Notifier<Svc>,
}

impl RobotPorts {
    /// Opens the run's services from `node` and creates robot `id`'s ports on them; the
    /// robot sleeps on the run's bell.
    pub fn open(node: &Node<Svc>, run: &RunServices, id: u32) -> Result<RobotPorts, IpcError> {
        let s = open_services(node, run, id)?;
        let bell = bell::Bell::open(run).map_err(|e| {
            format!(
                "cannot open the tick bell {}: {e}",
                bell::path(run).display()
            )
        })?;
        RobotPorts::on(
            &s.observations,
            &s.commands,
            &s.commands_event,
            TickWait::Bell(bell),
        )
    }

    /// As [`RobotPorts::open`], but the robot sleeps in its own listener of the observation
    /// event: one notification per robot per tick, as before the bell (the benchmarks' floor).
    pub fn open_listening(
        node: &Node<Svc>,
        run: &RunServices,
        id: u32,
    ) -> Result<RobotPorts, IpcError> {
        let s = open_services(node, run, id)?;
        let listener = s.observations_event.listener_builder().create()?;
        RobotPorts::on(
            &s.observations,
            &s.commands,
            &s.commands_event,
            TickWait::Listener(Box::new(listener)),
        )
    }

    /// A robot's ports on the services (opened, or created by a benchmark that plays the
    /// robot), sleeping as `wait` says.
    pub fn on(
        observations: &ObservationService,
        commands: &CommandService,
        commands_event: &EventService,
        wait: TickWait,
    ) -> Result<RobotPorts, IpcError> {
        Ok(RobotPorts {
            subscriber: observations.subscriber_builder().create()?,
            wait,
            publisher: commands.publisher_builder().create()?,
            notifier: commands_event
                .notifier_builder()
                .default_event_id(EventId::new(EVENT_COMMAND))
                .create()?,
        })
    }

    /// Sends `command` and wakes the world when it waits for this answer: on the bell, a
    /// robot counts its answer and only the one that completes the tick notifies
    /// ([`bell::Bell::answered`]); a listening robot always notifies.
    pub fn send(&self, command: Command) -> Result<(), IpcError> {
        self.publisher.send_copy(command)?;
        let notify = match &self.wait {
            TickWait::Bell(b) => b.answered(),
            TickWait::Listener(_) => true,
        };
        if notify {
            self.notifier.notify()?;
        }
        Ok(())
    }

    /// Says robot `id` is ready (its ports exist): the world binds the robot to this
    /// publisher from now on. Always wakes the world; not counted as an answer.
    pub fn hello(&self, id: u32) -> Result<(), IpcError> {
        self.publisher
            .send_copy(Command::hello(id, std::process::id()))?;
        self.notifier.notify()?;
        Ok(())
    }
}

/// Starts a thread that forwards every message of `from` to the returned receiver and then
/// wakes the listener of the run's command event (event [`EVENT_CONTROL`]), so a loop that
/// sleeps in that listener also wakes for link messages, control lines and reaped children.
/// Ends when every sender of `from` is gone.
pub fn wake_relay<T: Send + 'static>(
    run: &RunServices,
    node_name: String,
    from: crossbeam_channel::Receiver<T>,
) -> Result<crossbeam_channel::Receiver<T>, IpcError> {
    // As bounded as what it relays: a full queue stops the relay, not the bound.
    let (tx, rx) = match from.capacity() {
        Some(cap) => crossbeam_channel::bounded(cap),
        None => crossbeam_channel::unbounded(),
    };
    let (ready_tx, ready_rx) = crossbeam_channel::bounded::<Result<(), String>>(1);
    let run = run.clone();
    std::thread::Builder::new()
        .name("wake-relay".into())
        .spawn(move || {
            let made = node(&run, &node_name).and_then(|node| {
                let ev = open_commands_event(&node, &run)?;
                let n = ev
                    .notifier_builder()
                    .default_event_id(EventId::new(EVENT_CONTROL))
                    .create()?;
                Ok((node, n))
            });
            let (_node, notifier) = match made {
                Ok(x) => {
                    let _ = ready_tx.send(Ok(()));
                    x
                }
                Err(e) => {
                    let _ = ready_tx.send(Err(e.to_string()));
                    return;
                }
            };
            for m in from {
                if tx.send(m).is_err() {
                    return;
                }
                // The message is queued before the listener wakes.
                let _ = notifier.notify();
            }
        })?;
    ready_rx
        .recv()
        .map_err(|_| "wake relay died".to_string())??;
    Ok(rx)
}
