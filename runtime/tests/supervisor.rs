//! The robot lifecycle against a fake process table: the [`Supervisor`]'s orders are carried
//! out by [`launch::carry_out`] through [`FakeOs`], whose processes die, stop and continue as
//! real ones would, and whose deaths are fed back as reaps. No process is started.

use std::collections::BTreeMap;
use std::convert::Infallible;

use swarmrt_protocol::control::ProcessFault::{self, Freeze, Kill, Restart, Thaw};
use swarmrt_protocol::{Command, CommandKind, PROTOCOL_VERSION};
use swarmrt_runtime::supervisor::hello::{Bindings, Sample};
use swarmrt_runtime::supervisor::launch::{self, ShellSide};
use swarmrt_runtime::supervisor::{Ended, Event, Order, Pid, Signal, Stage, Supervisor};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Running,
    Stopped,
    /// Got SIGTERM while stopped: acts on it once continued.
    StoppedTerm,
}

/// Processes that obey signals; a dead one is queued for reaping.
#[derive(Default)]
struct FakeOs {
    next: Pid,
    procs: BTreeMap<Pid, State>,
    /// Processes that ignore SIGTERM (a hung robot).
    deaf: Vec<Pid>,
    dead: Vec<(Pid, String)>,
    signals: Vec<(Pid, Signal)>,
    /// What the supervisor handed over: [`Order::Ended`] and [`Order::OtherEnded`].
    news: Vec<Order>,
    /// Robots whose processes cannot be started, and the starts that failed.
    unstartable: Vec<u32>,
    failed: Vec<(u32, u32)>,
}

impl ShellSide for FakeOs {
    type Error = Infallible;

    fn spawn(&mut self, robot: u32, _incarnation: u32) -> std::io::Result<Pid> {
        if self.unstartable.contains(&robot) {
            return Err(std::io::Error::other("no such program"));
        }
        self.next += 1;
        let pid = 100 + self.next;
        self.procs.insert(pid, State::Running);
        Ok(pid)
    }

    fn not_started(
        &mut self,
        robot: u32,
        incarnation: u32,
        _: std::io::Error,
    ) -> Result<(), Infallible> {
        self.failed.push((robot, incarnation));
        Ok(())
    }

    fn ended(&mut self, ended: Ended) {
        self.news.push(Order::Ended(ended));
    }

    fn other_ended(&mut self, pid: Pid, how: String) {
        self.news.push(Order::OtherEnded { pid, how });
    }

    fn signal(&mut self, pids: &[Pid], signal: Signal) {
        for &pid in pids {
            self.signals.push((pid, signal));
            let Some(&state) = self.procs.get(&pid) else {
                continue;
            };
            match (signal, state) {
                (Signal::Kill, _) => self.exit(pid, "killed by signal 9"),
                (Signal::Stop, _) => {
                    self.procs.insert(pid, State::Stopped);
                }
                (Signal::Cont, State::StoppedTerm) => self.exit(pid, "killed by signal 15"),
                (Signal::Cont, _) => {
                    self.procs.insert(pid, State::Running);
                }
                (Signal::Term, _) if self.deaf.contains(&pid) => {}
                (Signal::Term, State::Running) => self.exit(pid, "killed by signal 15"),
                (Signal::Term, _) => {
                    self.procs.insert(pid, State::StoppedTerm);
                }
            }
        }
    }
}

impl FakeOs {
    fn exit(&mut self, pid: Pid, how: &str) {
        if self.procs.remove(&pid).is_some() {
            self.dead.push((pid, how.to_string()));
        }
    }

    fn carry_out(&mut self, sup: &mut Supervisor, orders: Vec<Order>) {
        let Ok(()) = launch::carry_out(sup, orders, self);
    }

    /// Tells the supervisor `event` and carries out its orders.
    fn on(&mut self, sup: &mut Supervisor, event: Event) {
        let Ok(()) = launch::handle(sup, event, self);
    }

    /// Reaps every dead process, as the reaper threads would; returns what was handed over.
    fn reap(&mut self, sup: &mut Supervisor) -> Vec<Order> {
        for (pid, how) in std::mem::take(&mut self.dead) {
            self.on(sup, Event::Reaped { pid, how });
        }
        std::mem::take(&mut self.news)
    }
}

fn started(n: u32) -> (Supervisor, FakeOs) {
    let mut sup = Supervisor::new();
    let mut os = FakeOs::default();
    for robot in 0..n {
        os.on(&mut sup, Event::Launch { robot });
    }
    (sup, os)
}

fn fault(sup: &mut Supervisor, f: ProcessFault) -> Vec<Order> {
    sup.on(Event::Fault(f))
}

#[test]
fn a_scheduled_kill_is_ordered_and_a_hung_robots_kill_is_a_death() {
    let (mut sup, mut os) = started(3);
    let p0 = sup.pid_of(0).unwrap();
    let p1 = sup.pid_of(1).unwrap();
    os.on(&mut sup, Event::Fault(Kill { robot: 0 }));
    os.on(&mut sup, Event::Hung { robot: 1 });
    let reaped = os.reap(&mut sup);
    assert_eq!(
        reaped,
        vec![
            Order::Ended(Ended {
                robot: 0,
                incarnation: 0,
                pid: p0,
                how: "killed by signal 9".into(),
                ordered: true
            }),
            Order::Ended(Ended {
                robot: 1,
                incarnation: 0,
                pid: p1,
                how: "killed by signal 9".into(),
                ordered: false
            }),
        ]
    );
    // A dead robot has no process to signal any more.
    assert_eq!(sup.pid_of(0), None);
    assert_eq!(fault(&mut sup, Kill { robot: 0 }), vec![]);
    assert_eq!(fault(&mut sup, Freeze { robot: 0 }), vec![]);
    assert_eq!(sup.on(Event::Hung { robot: 1 }), vec![]);
    let ordered: Vec<bool> = sup.processes().iter().map(|p| p.ordered).collect();
    assert_eq!(ordered, [true, false, false]);
}

#[test]
fn a_restart_kills_the_old_process_on_the_order_and_asks_for_the_next_incarnation() {
    let (mut sup, mut os) = started(2);
    let old = sup.pid_of(1).unwrap();
    let orders = fault(
        &mut sup,
        Restart {
            robot: 1,
            incarnation: 1,
        },
    );
    assert_eq!(
        orders,
        vec![
            Order::Signal {
                pids: vec![old],
                signal: Signal::Kill
            },
            Order::Spawn {
                robot: 1,
                incarnation: 1
            },
        ]
    );
    os.carry_out(&mut sup, orders);
    // The fresh process is the robot's even before the old one is reaped.
    let fresh = sup.pid_of(1).unwrap();
    assert_ne!(fresh, old);
    let reaped = os.reap(&mut sup);
    assert!(matches!(&reaped[..], [Order::Ended(e)] if e.pid == old && e.ordered));
    // A later kill reaches the fresh process, not the old one.
    assert_eq!(
        fault(&mut sup, Kill { robot: 1 }),
        vec![Order::Signal {
            pids: vec![fresh],
            signal: Signal::Kill
        }]
    );
    let history: Vec<(u32, u32, bool)> = sup
        .processes()
        .iter()
        .map(|p| (p.robot, p.incarnation, p.end.is_some()))
        .collect();
    assert_eq!(history, [(0, 0, false), (1, 0, true), (1, 1, false)]);
}

#[test]
fn a_restart_of_a_robot_without_a_process_only_spawns() {
    let (mut sup, mut os) = started(1);
    os.on(&mut sup, Event::Fault(Kill { robot: 0 }));
    os.reap(&mut sup);
    assert_eq!(
        fault(
            &mut sup,
            Restart {
                robot: 0,
                incarnation: 1
            }
        ),
        vec![Order::Spawn {
            robot: 0,
            incarnation: 1
        }]
    );
}

#[test]
fn a_failed_start_is_the_shells_and_leaves_no_process_behind() {
    let (mut sup, mut os) = started(1);
    os.unstartable.push(0);
    let old = sup.pid_of(0).unwrap();
    os.on(
        &mut sup,
        Event::Fault(Restart {
            robot: 0,
            incarnation: 1,
        }),
    );
    // The old process was still killed on the order; the fresh one never ran.
    assert_eq!(os.failed, [(0, 1)]);
    assert_eq!(sup.pid_of(0), None);
    assert!(matches!(&os.reap(&mut sup)[..], [Order::Ended(e)] if e.pid == old && e.ordered));
    assert!(sup.is_empty());
    assert_eq!(sup.processes().len(), 1);
}

#[test]
fn a_frozen_robot_is_continued_before_shutdown_and_a_thawed_one_is_not() {
    let (mut sup, mut os) = started(3);
    let (p0, p1) = (sup.pid_of(0).unwrap(), sup.pid_of(1).unwrap());
    os.on(&mut sup, Event::Fault(Freeze { robot: 0 }));
    os.on(&mut sup, Event::Fault(Freeze { robot: 1 }));
    os.on(&mut sup, Event::Fault(Thaw { robot: 1 }));
    assert_eq!(os.procs[&p0], State::Stopped);
    assert_eq!(os.procs[&p1], State::Running);
    let orders = sup.on(Event::ShutDown);
    assert_eq!(
        orders,
        vec![Order::Signal {
            pids: vec![p0],
            signal: Signal::Cont
        }]
    );
    os.carry_out(&mut sup, orders);
    assert!(os.procs.values().all(|s| *s == State::Running));
    // Nothing is left frozen: a second shutdown continues nobody.
    assert!(sup.on(Event::ShutDown).is_empty());
}

#[test]
fn a_frozen_robot_that_is_killed_is_not_continued() {
    let (mut sup, mut os) = started(1);
    os.on(&mut sup, Event::Fault(Freeze { robot: 0 }));
    os.on(&mut sup, Event::Fault(Kill { robot: 0 }));
    assert!(sup.on(Event::ShutDown).is_empty());
    assert_eq!(os.reap(&mut sup).len(), 1);
    assert!(sup.is_empty());
}

#[test]
fn shutdown_escalates_from_sigterm_to_sigkill_then_gives_up() {
    let (mut sup, mut os) = started(3);
    // The world, say: seen out with the robots, untouched by faults.
    os.on(&mut sup, Event::Watch { pid: 42 });
    os.procs.insert(42, State::Running);
    let (p0, p1, p2) = (
        sup.pid_of(0).unwrap(),
        sup.pid_of(1).unwrap(),
        sup.pid_of(2).unwrap(),
    );
    os.deaf.push(p2);
    os.on(&mut sup, Event::Fault(Freeze { robot: 1 }));
    os.on(&mut sup, Event::ShutDown);
    assert_eq!(sup.stage(), Stage::Grace);
    // Robot 0 exits on the shutdown sample by itself.
    os.exit(p0, "exited with code 0");
    os.reap(&mut sup);
    // Grace over: SIGTERM, then SIGCONT to the same processes.
    let orders = sup.on(Event::Overdue);
    assert_eq!(
        orders,
        vec![
            Order::Signal {
                pids: vec![42, p1, p2],
                signal: Signal::Term
            },
            Order::Signal {
                pids: vec![42, p1, p2],
                signal: Signal::Cont
            },
        ]
    );
    os.carry_out(&mut sup, orders);
    let reaped = os.reap(&mut sup);
    assert!(reaped.contains(&Order::OtherEnded {
        pid: 42,
        how: "killed by signal 15".into()
    }));
    assert_eq!(sup.live_pids(), vec![p2], "only the deaf robot is left");
    let orders = sup.on(Event::Overdue);
    assert_eq!(
        orders,
        vec![Order::Signal {
            pids: vec![p2],
            signal: Signal::Kill
        }]
    );
    assert_eq!(sup.stage(), Stage::Killed);
    // Suppose even SIGKILL was not reaped (a lost reaper): nothing more to send.
    assert_eq!(sup.on(Event::Overdue), vec![Order::GiveUp]);
    assert_eq!(sup.stage(), Stage::GaveUp);
    os.carry_out(&mut sup, orders);
    os.reap(&mut sup);
    assert!(sup.is_empty());
}

#[test]
fn no_robot_is_started_once_the_run_is_ending() {
    let (mut sup, mut os) = started(2);
    os.on(&mut sup, Event::ShutDown);
    assert_eq!(sup.on(Event::Launch { robot: 5 }), vec![]);
    let p1 = sup.pid_of(1).unwrap();
    assert_eq!(
        fault(
            &mut sup,
            Restart {
                robot: 1,
                incarnation: 1
            }
        ),
        vec![Order::Signal {
            pids: vec![p1],
            signal: Signal::Kill
        }]
    );
}

#[test]
fn kill_all_kills_every_process_and_unknown_pids_are_not_reaped() {
    let (mut sup, mut os) = started(2);
    os.on(&mut sup, Event::Watch { pid: 7 });
    os.procs.insert(7, State::Stopped);
    let orders = sup.on(Event::KillAll);
    assert_eq!(
        orders,
        vec![Order::Signal {
            pids: {
                let mut p = sup.live_pids();
                p.sort();
                p
            },
            signal: Signal::Kill
        }]
    );
    os.carry_out(&mut sup, orders);
    assert_eq!(os.reap(&mut sup).len(), 3);
    assert!(sup.is_empty());
    let again = Event::Reaped {
        pid: 7,
        how: "again".into(),
    };
    assert_eq!(sup.on(again), vec![]);
    let never = Event::Reaped {
        pid: 9999,
        how: "never ours".into(),
    };
    assert_eq!(sup.on(never), vec![]);
}

fn command(robot: u32, kind: CommandKind) -> Command {
    match kind {
        CommandKind::Hello => Command::hello(robot, 1),
        CommandKind::Act => Command::act(robot, 0),
        CommandKind::React => Command {
            kind: CommandKind::React as u32,
            ..Command::act(robot, 0)
        },
    }
}

#[test]
fn only_a_hello_takes_a_robots_waiting_slot() {
    let mut b: Bindings<&str> = Bindings::awaiting([0, 1]);
    // A command before any hello (what a remote host's entry could do before): ignored, and
    // the robot still waits for its hello.
    assert_eq!(
        b.accept("p", &command(0, CommandKind::Act)),
        Sample::Unknown
    );
    assert!(b.is_awaiting(0));
    assert_eq!(
        b.accept("p", &command(0, CommandKind::Hello)),
        Sample::Hello(0)
    );
    assert!(!b.is_awaiting(0));
    // Later samples from that origin are robot 0's, whatever id they write.
    assert_eq!(
        b.accept("p", &command(1, CommandKind::Hello)),
        Sample::Robot(0)
    );
    assert!(b.is_awaiting(1));
    // Another origin claiming the taken id is refused.
    assert_eq!(
        b.accept("q", &command(0, CommandKind::Hello)),
        Sample::BadHello
    );
    // A hello of another protocol version is no hello.
    let mut old = command(1, CommandKind::Hello);
    old.version = PROTOCOL_VERSION + 1;
    assert_eq!(b.accept("q", &old), Sample::Unknown);
    assert!(b.is_awaiting(1));
}

#[test]
fn a_restart_unbinds_the_old_process_and_waits_for_the_fresh_ones_hello() {
    let mut b: Bindings<u32> = Bindings::awaiting([3]);
    assert_eq!(
        b.accept(10, &command(3, CommandKind::Hello)),
        Sample::Hello(3)
    );
    b.expect_hello(3);
    assert!(!b.is_bound(3));
    // The old process's late answer is no robot's any more.
    assert_eq!(b.accept(10, &command(3, CommandKind::Act)), Sample::Unknown);
    assert_eq!(
        b.accept(11, &command(3, CommandKind::Hello)),
        Sample::Hello(3)
    );
    assert_eq!(
        b.accept(11, &command(3, CommandKind::Act)),
        Sample::Robot(3)
    );
    // A kill: unbound, and no hello awaited.
    b.forget(3);
    assert_eq!(
        b.accept(12, &command(3, CommandKind::Hello)),
        Sample::BadHello
    );
    assert!(b.awaiting_set().is_empty());
}

#[test]
fn an_origin_may_claim_only_the_robots_it_is_allowed() {
    let mut b: Bindings<u32> = Bindings::awaiting([4, 5]);
    // A remote host's entry attributed to robot 4 that claims robot 5.
    assert_eq!(
        b.accept_claiming(4, &command(5, CommandKind::Hello), |r| r == 4),
        Sample::BadHello
    );
    assert!(b.is_awaiting(5), "a refused claim takes no slot");
    assert_eq!(
        b.accept_claiming(4, &command(4, CommandKind::Hello), |r| r == 4),
        Sample::Hello(4)
    );
}
