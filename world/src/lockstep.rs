//! The one lock-step tick, whoever the robots are: the faults the world applied at the tick
//! boundary are carried out, every robot that expects a command answers its observation, the
//! propagation rounds run, and the world steps. The in-process harness (robot cores called in
//! this process) and the world process (robot processes over shared memory, remote hosts
//! behind them) implement [`Robots`] and call [`tick`], so the order of a tick is written
//! once and both modes write the same bytes.

use swarmrt_protocol::{Command, RoundInbox};

use crate::{ProcessSignal, World};

/// How a lock-step loop reaches its robots.
pub trait Robots {
    /// What can fail on the way to them (nothing, in-process).
    type Error;

    /// Carries out the process faults and rejoins of this tick boundary, as the world
    /// applied them to its own state (restart a core, signal a process, wait for a hello).
    fn carry_out(
        &mut self,
        world: &mut World,
        signals: Vec<ProcessSignal>,
    ) -> Result<(), Self::Error>;

    /// Every robot that expects a command answers its observation of this tick: `commands`
    /// holds one slot per robot afterwards, `None` where no answer came.
    fn answer(
        &mut self,
        world: &mut World,
        commands: &mut Vec<Option<Command>>,
    ) -> Result<(), Self::Error>;

    /// The robots woken in a propagation round react to what they heard within the tick:
    /// each one's reaction into `reactions[robot]` (left `None` where none came).
    fn react(
        &mut self,
        world: &mut World,
        round: &[RoundInbox],
        reactions: &mut [Option<Command>],
    ) -> Result<(), Self::Error>;

    /// True once the run must stop before the world steps again (a Stop, a signal).
    fn stopped(&self) -> bool {
        false
    }

    /// Called right before the world steps: the answers are all in (a shell's clock).
    fn stepping(&mut self) {}
}

/// One tick: faults, answers, rounds, step. False when the robots stopped the run before
/// the world could step (nothing of the tick is recorded then).
pub fn tick<R: Robots>(
    world: &mut World,
    robots: &mut R,
    commands: &mut Vec<Option<Command>>,
) -> Result<bool, R::Error> {
    Ok(begin(world, robots, commands)? && finish(world, robots, commands)?)
}

/// The first half of [`tick`]: the faults carried out, every robot's answer. A loop whose
/// robots answer outside the call (a learning environment's policy, between two calls) runs
/// the tick as `begin`, their answers into `commands`, then [`finish`].
pub fn begin<R: Robots>(
    world: &mut World,
    robots: &mut R,
    commands: &mut Vec<Option<Command>>,
) -> Result<bool, R::Error> {
    let signals = world.take_signals();
    robots.carry_out(world, signals)?;
    if robots.stopped() {
        return Ok(false);
    }
    robots.answer(world, commands)?;
    Ok(!robots.stopped())
}

/// The second half of [`tick`]: the propagation rounds and the world's step.
pub fn finish<R: Robots>(
    world: &mut World,
    robots: &mut R,
    commands: &mut [Option<Command>],
) -> Result<bool, R::Error> {
    propagate(world, robots, commands)?;
    if robots.stopped() {
        return Ok(false);
    }
    robots.stepping();
    world.step(commands);
    Ok(true)
}

/// The tick's propagation rounds (`radio.rounds` > 0; nothing otherwise): each round the
/// world routes the frames sent within the tick, the robots woken with some react, and the
/// world applies their reactions in ascending robot order.
pub fn propagate<R: Robots>(
    world: &mut World,
    robots: &mut R,
    commands: &mut [Option<Command>],
) -> Result<(), R::Error> {
    if !world.has_rounds() {
        return Ok(());
    }
    world.start_rounds(commands);
    let mut reactions = vec![None; commands.len()];
    loop {
        let round = world.next_round();
        if round.is_empty() {
            return Ok(());
        }
        reactions.iter_mut().for_each(|r| *r = None);
        robots.react(world, &round, &mut reactions)?;
        for inbox in &round {
            let answer = reactions[inbox.robot as usize];
            world.react(inbox.robot, answer.as_ref(), commands);
        }
        if robots.stopped() {
            return Ok(());
        }
    }
}
