//! The command inbox, one for the world's lock-step, its real-time mode and `swarm-host`:
//! every queued command sample is received, attributed by its publisher's hello binding and
//! classified ([`Sample`]) before anyone reads what it says.

use iceoryx2::identifiers::UniquePublisherId;
use swarmrt_ipc::{CommandSubscribers, IpcError};
use swarmrt_protocol::Command;

use crate::supervisor::hello::{Bindings, Sample};

/// Drains `commands`, handing each sample to `take` with what it is: `origin` names the
/// sample's publisher in `bindings`' terms, and an unbound publisher's hello may claim only
/// the robots `may_claim` allows (on the world's host, none of a remote host).
pub fn receive<K: Ord + Clone>(
    commands: &CommandSubscribers,
    bindings: &mut Bindings<K>,
    origin: impl Fn(UniquePublisherId) -> K,
    may_claim: impl Fn(u32) -> bool,
    mut take: impl FnMut(Sample, Command),
) -> Result<(), IpcError> {
    while let Some(sample) = commands.receive()? {
        let from = origin(sample.origin());
        let c = *sample.payload();
        // The sample goes back to its publisher before the command is looked at.
        drop(sample);
        let what = bindings.accept_claiming(from, &c, &may_claim);
        take(what, c);
    }
    Ok(())
}
