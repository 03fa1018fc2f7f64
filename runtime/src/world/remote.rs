//! The remote hosts of a `--hosts` run, as the world's shell sees them: each host's slots go
//! down over Zenoh per tick, its robots' answers come up and are bound by the same rule as
//! local ones; a host whose messages were dropped is asked to send them again.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use swarmrt_hosts::HostsFile;
use swarmrt_hosts::wire::{Down, Up, encode_tick};
use swarmrt_hosts::world_side::{Heard, Resends, WorldLink};
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::control::WorldReport;
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{Command, Observation, RobotState};
use swarmrt_world::World;

use super::answers::{Answers, Hellos, Origin};
use super::control::report;
use super::stats::ShellStats;
use crate::supervisor::hello::is_hello;

/// How long the world waits at the end for every host to say its robots are gone, before it
/// closes its session anyway.
const BYE_TIMEOUT: Duration = Duration::from_secs(8);

/// The remote hosts of a `--hosts` run.
pub(super) struct Remote {
    link: WorldLink,
    heard: Receiver<Heard>,
    /// What a host must present to join: [`swarmrt_hosts::link::layout`] of the config.
    layout: u32,
    names: Vec<String>,
    joined: Vec<bool>,
    lost: Vec<bool>,
    byes: usize,
    /// When to ask a host whose messages were dropped to send them again.
    resends: Resends,
}

impl Remote {
    pub(super) fn open(
        run: &RunServices,
        hosts: &HostsFile,
        layout: u32,
    ) -> Result<Remote, IpcError> {
        let (link, heard) = WorldLink::open(hosts, run.run_id())?;
        let heard = ipc::wake_relay(run, format!("{}-link", run.world_node_name()), heard)?;
        let n = hosts.hosts.len();
        Ok(Remote {
            link,
            heard,
            layout,
            names: hosts.hosts.iter().map(|h| h.name.clone()).collect(),
            joined: vec![false; n],
            lost: vec![false; n],
            byes: 0,
            resends: Resends::new(n),
        })
    }

    /// Sends each live host its slots of this tick and which of its robots the world waits for.
    pub(super) fn send_tick(
        &mut self,
        tick: u64,
        obs: &[Observation],
        waiting: &BTreeSet<u32>,
    ) -> Result<(), IpcError> {
        for i in 0..self.link.len() {
            if self.lost[i] {
                continue;
            }
            let r = self.link.robots(i);
            let expect: Vec<u32> = waiting.range(r.clone()).copied().collect();
            let bytes = encode_tick(tick, &expect, &obs[r.start as usize..r.end as usize]);
            self.link.send_bytes(i, bytes)?;
        }
        Ok(())
    }

    /// Applies what the hosts said: joins, byes, and their robots' commands, bound by the
    /// same rule as local ones (an entry may claim only the robot it is attributed to).
    /// Takes at most what was queued when it started, so a host that floods cannot keep
    /// the world here.
    pub(super) fn drain(
        &mut self,
        world: &mut World,
        hellos: &mut Hellos,
        answers: &mut Answers,
        stats: &mut ShellStats,
    ) -> Result<(), IpcError> {
        for _ in 0..self.heard.len() {
            let Ok(h) = self.heard.try_recv() else {
                break;
            };
            match h {
                Heard::Malformed { host, .. } => self.link.count_up(host, 0, true),
                Heard::Lost { host } => self.lose(host, world, hellos, answers),
                Heard::Up {
                    host, msg, bytes, ..
                } => {
                    self.link.count_up(host, bytes, false);
                    let at = world.tick();
                    self.heard_up(host, msg, at, hellos, answers, stats)?;
                }
            }
        }
        self.ask_resends(world.tick(), hellos, &answers.pending)
    }

    /// One message a host sent up, while the world is at tick `at`.
    fn heard_up(
        &mut self,
        host: usize,
        msg: Up,
        at: u64,
        hellos: &mut Hellos,
        answers: &mut Answers,
        stats: &mut ShellStats,
    ) -> Result<(), IpcError> {
        match msg {
            Up::Join { host: name, layout } => self.join(host, &name, layout),
            Up::Bye => {
                self.byes += 1;
                Ok(())
            }
            Up::Commands(entries) => {
                let range = self.link.robots(host);
                for (robot, c) in entries {
                    if !range.contains(&robot) {
                        stats.unknown_sender += 1;
                        continue;
                    }
                    let sample = hellos
                        .accept_claiming(Origin::Remote(robot), &c, |claimed| claimed == robot);
                    answers.take(sample, c, stats);
                }
                Ok(())
            }
            Up::Resent {
                tick,
                answers: again,
                hellos: hello_again,
            } => {
                let current = (tick == at).then_some(again.as_slice());
                let recovered = self.resent(host, current, &hello_again, hellos, answers, stats);
                self.link.count_recovered(host, recovered);
                Ok(())
            }
        }
    }

    /// A host's join: welcomed when it runs this build and config, refused otherwise (before
    /// it joined that fails the run; a second join is counted and the host goes on).
    fn join(&mut self, host: usize, name: &str, layout: u32) -> Result<(), IpcError> {
        if layout == self.layout && name == self.names[host] {
            self.joined[host] = true;
            return self.link.send(host, &Down::Welcome);
        }
        let why = format!(
            "host {:?} runs another swarmrt build or config (layout {layout:08x}, the world's {:08x})",
            self.names[host], self.layout
        );
        self.link.send(host, &Down::Refuse(why.clone()))?;
        if !self.joined[host] {
            // Before it joined: the run cannot start as configured.
            return Err(why.into());
        }
        self.link.count_bad_join(host);
        tracing::warn!("refused a second join: {why}");
        Ok(())
    }

    /// What a host sent again on the world's asking: only what the world still waits for (a
    /// resend of something that did arrive is no robot's second answer), the answers only when
    /// they are of the current tick (`current`). Returns how many were taken.
    fn resent(
        &mut self,
        host: usize,
        current: Option<&[(u32, Command)]>,
        hello_again: &[(u32, Command)],
        hellos: &mut Hellos,
        answers: &mut Answers,
        stats: &mut ShellStats,
    ) -> u64 {
        let range = self.link.robots(host);
        let mut recovered = 0;
        for &(robot, c) in hello_again {
            if range.contains(&robot) && hellos.is_awaiting(robot) && is_hello(&c) {
                let sample = hellos.accept_claiming(Origin::Remote(robot), &c, |r| r == robot);
                answers.take(sample, c, stats);
                recovered += 1;
            }
        }
        for &(robot, c) in current.unwrap_or_default() {
            if range.contains(&robot) && answers.pending.contains(&robot) && hellos.is_bound(robot)
            {
                let sample = hellos.accept_claiming(Origin::Remote(robot), &c, |_| false);
                answers.take(sample, c, stats);
                recovered += 1;
            }
        }
        recovered
    }

    /// Asks each host whose messages were dropped while the world waits for some of its
    /// robots to send again what the world has not got ([`Resends`] says when).
    fn ask_resends(
        &mut self,
        tick: u64,
        hellos: &Hellos,
        pending: &BTreeSet<u32>,
    ) -> Result<(), IpcError> {
        let now = Instant::now();
        for i in 0..self.link.len() {
            let range = self.link.robots(i);
            let awaiting = hellos.awaiting_set();
            // A lost host, or one not joined yet, is asked nothing (and owes no wake-up).
            let waiting = !self.lost[i]
                && self.joined[i]
                && (pending.range(range.clone()).next().is_some()
                    || awaiting.range(range.clone()).next().is_some());
            if self.resends.due(i, self.link.dropped(i), waiting, now) {
                let answers: Vec<u32> = pending.range(range.clone()).copied().collect();
                let awaited: Vec<u32> = awaiting.range(range).copied().collect();
                tracing::debug!(host = %self.names[i], tick, ?answers, hellos = ?awaited, "asking for a resend");
                self.link.count_resend(i);
                self.link.send(
                    i,
                    &Down::Resend {
                        tick,
                        answers,
                        hellos: awaited,
                    },
                )?;
            }
        }
        Ok(())
    }

    /// When the world must look again for a resend to ask, though nothing wakes it.
    pub(super) fn next_look(&self) -> Option<Instant> {
        self.resends.next()
    }

    /// A host's session is gone: its robots are dead from this tick.
    fn lose(&mut self, host: usize, world: &mut World, hellos: &mut Hellos, answers: &mut Answers) {
        if self.lost[host] {
            return;
        }
        self.lost[host] = true;
        let mut robots = Vec::new();
        for r in self.link.robots(host) {
            hellos.forget(r);
            answers.pending.remove(&r);
            if world.robots()[r as usize].state != RobotState::Dead {
                world.mark_dead(r, &format!("host {} lost", self.names[host]));
                robots.push(r);
            }
        }
        tracing::warn!(host = %self.names[host], ?robots, "host lost; its robots are dead");
        report(&WorldReport::HostLost {
            host: self.names[host].clone(),
            robots,
        });
    }

    /// Tells every live host the run is over and waits (bounded) until each has seen its
    /// robots out, so the shutdown is delivered before the session closes.
    pub(super) fn finish(mut self, tick: u64, stats: &mut ShellStats) {
        let mut expected = 0;
        for i in 0..self.link.len() {
            if !self.lost[i] && self.link.send(i, &Down::Shutdown { tick }).is_ok() {
                expected += usize::from(self.joined[i]);
            }
        }
        let until = Instant::now() + BYE_TIMEOUT;
        while self.byes < expected {
            match self.heard.recv_deadline(until) {
                Ok(Heard::Up {
                    host, msg, bytes, ..
                }) => {
                    self.link.count_up(host, bytes, false);
                    if msg == Up::Bye {
                        self.byes += 1;
                    }
                }
                Ok(Heard::Lost { host }) if !self.lost[host] => {
                    self.lost[host] = true;
                    expected -= usize::from(self.joined[host]);
                }
                Ok(_) => {}
                Err(_) => break,
            }
        }
        stats.link = self.link.traffic().to_vec();
        stats.tls = Some(swarmrt_hosts::noise::refused());
        self.link.close();
    }
}
