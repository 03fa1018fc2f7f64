//! The services of in-tick propagation rounds (`radio.rounds` > 0), created only then: a
//! round sample service holding the inboxes of the robots woken in the round, and one wake-up
//! event service per robot, so a round wakes only the robots it has frames for (the tick's
//! observation wakes every robot through its own service too, so a robot sleeps in one
//! listener).

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;

use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{PROTOCOL_VERSION, RoundHeader, RoundInbox};

use crate::{IpcError, OBSERVATION_SAMPLES, Svc, service_name};

/// The round sample service handle.
pub type RoundService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, [RoundInbox], RoundHeader>;
type EventService = iceoryx2::service::port_factory::event::PortFactory<Svc>;

/// Listeners a robot's wake-up service admits: its process, a restarted one whose old
/// port is not yet reclaimed, and a spare.
const WAKE_LISTENERS: usize = 3;

/// The world's side: the round publisher and every robot's wake-up notifier.
pub struct WorldRounds {
    publisher: Publisher<Svc, [RoundInbox], RoundHeader>,
    wake: Vec<Notifier<Svc>>,
    _services: (RoundService, Vec<EventService>),
}

impl WorldRounds {
    /// Creates the round services of a run of `robots` robots (`spare` extra subscriber and
    /// node slots, as for the observation service).
    pub fn create(
        node: &Node<Svc>,
        run: &RunServices,
        robots: usize,
        spare: usize,
    ) -> Result<WorldRounds, IpcError> {
        let n = robots + spare;
        let samples = node
            .service_builder(&service_name(&run.rounds())?)
            .publish_subscribe::<[RoundInbox]>()
            .user_header::<RoundHeader>()
            .max_publishers(1)
            .max_subscribers(n)
            .max_nodes(n + 2)
            .subscriber_max_buffer_size(1)
            .subscriber_max_borrowed_samples(1)
            .history_size(0)
            .enable_safe_overflow(true)
            .create()?;
        let publisher = samples
            .publisher_builder()
            .initial_max_slice_len(robots.max(1))
            // As for observations: every robot holds at most the newest round and the one it
            // reads, so a few samples suffice.
            .override_sample_preallocation(|_| OBSERVATION_SAMPLES)
            .create()?;
        let mut events = Vec::with_capacity(robots);
        let mut wake = Vec::with_capacity(robots);
        for id in 0..robots as u32 {
            let ev = node
                .service_builder(&service_name(&run.robot_wake(id))?)
                .event()
                .max_notifiers(1)
                .max_listeners(WAKE_LISTENERS)
                .max_nodes(WAKE_LISTENERS + 1)
                .create()?;
            wake.push(ev.notifier_builder().create()?);
            events.push(ev);
        }
        Ok(WorldRounds {
            publisher,
            wake,
            _services: (samples, events),
        })
    }

    /// Wakes robot `robot` (for the tick's observation).
    pub fn wake(&self, robot: u32) -> Result<(), IpcError> {
        if let Some(n) = self.wake.get(robot as usize) {
            n.notify()?;
        }
        Ok(())
    }

    /// Publishes round `round` of `tick` and wakes exactly the robots it holds.
    pub fn publish(&self, tick: u64, round: u32, inboxes: &[RoundInbox]) -> Result<(), IpcError> {
        let sample = self.publisher.loan_slice_uninit(inboxes.len())?;
        let mut sample = sample.write_from_slice(inboxes);
        *sample.user_header_mut() = RoundHeader {
            version: PROTOCOL_VERSION,
            round,
            tick,
        };
        sample.send()?;
        for b in inboxes {
            self.wake(b.robot)?;
        }
        Ok(())
    }
}

/// A robot's side: the round samples and its own wake-up.
pub struct RobotRounds {
    /// Round samples (only the newest is kept).
    pub subscriber: Subscriber<Svc, [RoundInbox], RoundHeader>,
    /// Woken for the tick's observation and for each round that has frames for it.
    pub listener: Listener<Svc>,
    _services: (RoundService, EventService),
}

impl RobotRounds {
    /// Opens robot `id`'s round ports on the services the world created.
    pub fn open(node: &Node<Svc>, run: &RunServices, id: u32) -> Result<RobotRounds, IpcError> {
        let samples = node
            .service_builder(&service_name(&run.rounds())?)
            .publish_subscribe::<[RoundInbox]>()
            .user_header::<RoundHeader>()
            .open()?;
        let ev = node
            .service_builder(&service_name(&run.robot_wake(id))?)
            .event()
            .open()?;
        Ok(RobotRounds {
            subscriber: samples.subscriber_builder().create()?,
            listener: ev.listener_builder().create()?,
            _services: (samples, ev),
        })
    }
}
