//! Where a multi-process run is, once its world listens: one state whose transitions are
//! written here and nowhere else.

use crate::hosts::HostFailure;

/// The phase of a run's main loop.
#[derive(Debug)]
pub(super) enum Phase {
    /// Robots start and say hello. A host lost now fails the run.
    Starting,
    /// The world reported tick 0: a host lost now only kills its robots.
    Running,
    /// A Ctrl-C told the world to stop (`ready`: tick 0 came first); another kills everything.
    Stopping {
        /// The world reported tick 0.
        ready: bool,
    },
    /// The main loop is over: the world reported its end or failed, or a host failed before
    /// tick 0 (`failure`, the run's error). Robot ends are no news any more.
    Done {
        /// The host that failed the run.
        failure: Option<HostFailure>,
    },
}

/// What moves a run on.
#[derive(Debug)]
pub(super) enum Step {
    /// The world reported tick 0.
    Ready,
    /// A Ctrl-C.
    Interrupt,
    /// A host was lost before tick 0.
    HostFailed(HostFailure),
    /// The world reported its end, or ended without reporting it.
    Over,
}

/// What a step asks of the shell.
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Then {
    /// Nothing.
    Nothing,
    /// Tell the world to stop (the first Ctrl-C).
    StopWorld,
    /// Stop the world and every other host (a host failed the run).
    StopAll,
    /// Kill every process at once (a second Ctrl-C).
    KillAll,
}

impl Phase {
    /// Takes `step`; what the shell must do for it.
    pub(super) fn next(&mut self, step: Step) -> Then {
        let ready = self.ready();
        let (phase, then) = match (std::mem::replace(self, Phase::Starting), step) {
            (done @ Phase::Done { .. }, Step::Interrupt) => (done, Then::KillAll),
            (done @ Phase::Done { .. }, _) => (done, Then::Nothing),
            (Phase::Starting, Step::Ready) => (Phase::Running, Then::Nothing),
            (Phase::Stopping { .. }, Step::Ready) => {
                (Phase::Stopping { ready: true }, Then::Nothing)
            }
            (Phase::Stopping { ready }, Step::Interrupt) => {
                (Phase::Stopping { ready }, Then::KillAll)
            }
            (_, Step::Interrupt) => (Phase::Stopping { ready }, Then::StopWorld),
            (phase, Step::HostFailed(_)) if ready => (phase, Then::Nothing),
            (_, Step::HostFailed(f)) => (Phase::Done { failure: Some(f) }, Then::StopAll),
            (_, Step::Over) => (Phase::Done { failure: None }, Then::Nothing),
            (phase, Step::Ready) => (phase, Then::Nothing),
        };
        *self = phase;
        then
    }

    /// True once tick 0 was reported (while the main loop runs).
    pub(super) fn ready(&self) -> bool {
        matches!(self, Phase::Running | Phase::Stopping { ready: true })
    }

    /// True while robots are still being started.
    pub(super) fn starting(&self) -> bool {
        matches!(self, Phase::Starting)
    }

    /// True once the main loop is over.
    pub(super) fn is_done(&self) -> bool {
        matches!(self, Phase::Done { .. })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn failure() -> HostFailure {
        HostFailure {
            host: "b".into(),
            why: "gone".into(),
        }
    }

    #[test]
    fn a_first_ctrl_c_stops_the_world_and_the_next_kill_everything() {
        let mut p = Phase::Starting;
        assert_eq!(p.next(Step::Interrupt), Then::StopWorld);
        assert!(!p.ready());
        assert_eq!(p.next(Step::Ready), Then::Nothing);
        assert!(p.ready());
        assert_eq!(p.next(Step::Interrupt), Then::KillAll);
        assert_eq!(p.next(Step::Interrupt), Then::KillAll);
        assert_eq!(p.next(Step::Over), Then::Nothing);
        assert!(p.is_done());
    }

    #[test]
    fn a_host_lost_before_tick_0_fails_the_run_and_after_it_does_not() {
        let mut p = Phase::Starting;
        assert_eq!(p.next(Step::HostFailed(failure())), Then::StopAll);
        assert!(matches!(p, Phase::Done { failure: Some(_) }));
        // The first failure is the run's.
        assert_eq!(p.next(Step::HostFailed(failure())), Then::Nothing);
        let mut p = Phase::Starting;
        p.next(Step::Ready);
        assert_eq!(p.next(Step::HostFailed(failure())), Then::Nothing);
        assert!(matches!(p, Phase::Running));
        let mut p = Phase::Stopping { ready: false };
        assert_eq!(p.next(Step::HostFailed(failure())), Then::StopAll);
    }

    #[test]
    fn the_end_is_final() {
        let mut p = Phase::Running;
        p.next(Step::Over);
        assert_eq!(p.next(Step::Ready), Then::Nothing);
        assert!(matches!(p, Phase::Done { failure: None }));
    }
}
