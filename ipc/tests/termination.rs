//! A termination request survives the signals that follow it. Its own test binary: it installs
//! process-wide signal handlers and raises signals at itself.

use swarmrt_ipc as ipc;
use swarmrt_ipc::cleanup;
use swarmrt_protocol::services::RunServices;

/// The orchestrator sends SIGTERM and then SIGCONT (so that a stopped robot can act on it).
/// iceoryx2's own handler keeps only the last signal, so the robot saw SIGCONT, never the
/// request, and was SIGKILLed after its grace period.
#[test]
fn sigterm_followed_by_sigcont_is_still_a_termination_request() {
    let run_id = format!("{:012x}", std::process::id() as u64 * 7919 + 0xabc);
    let run = RunServices::new(&run_id);
    let node = ipc::node(&run, "termination-test").unwrap();
    assert!(!ipc::termination_requested(&node), "no signal yet");
    // SAFETY: raising signals at ourselves; SIGTERM is handled once a node exists.
    unsafe {
        libc::raise(libc::SIGCONT);
    }
    assert!(!ipc::termination_requested(&node), "SIGCONT is no request");
    unsafe {
        libc::raise(libc::SIGTERM);
        libc::raise(libc::SIGCONT);
        libc::raise(libc::SIGCHLD);
    }
    assert!(ipc::termination_requested(&node));
    assert!(ipc::termination_requested(&node), "the request sticks");
    drop(node);
    cleanup::remove_run(&run_id);
    assert!(cleanup::leftovers(&run_id).is_empty());
}
