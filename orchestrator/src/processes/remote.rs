//! What the orchestrator keeps of the robots on remote hosts: the orders their swarm-hosts
//! get, and their processes' starts and ends as the hosts report them.

use std::collections::BTreeMap;

use swarmrt_protocol::control::{HostControl, HostReport, ProcessFault, WorldReport};

/// Remote robot processes: (host, pid, robot, incarnation) in start order.
pub(super) type RemoteStarts = Vec<(usize, i32, u32, u32)>;
/// How each remote robot process ended: (host, pid) -> (how, killed on an order).
pub(super) type RemoteEnds = BTreeMap<(usize, i32), (String, bool)>;

/// The order for a remote robot's swarm-host that a world report asks for, if any: the
/// fault as it is, and an unresponsive robot's kill.
pub(super) fn remote_order(r: &WorldReport) -> Option<(u32, HostControl)> {
    match *r {
        WorldReport::Fault(fault) => Some((fault.robot(), HostControl::Fault(fault))),
        WorldReport::Unresponsive { robot, .. } => {
            Some((robot, HostControl::Fault(ProcessFault::Kill { robot })))
        }
        _ => None,
    }
}

/// Notes a remote robot process's start or end; an end is returned (robot, how, ordered).
pub(super) fn record_remote(
    host: usize,
    report: &HostReport,
    started: &mut RemoteStarts,
    ended: &mut RemoteEnds,
) -> Option<(u32, String, bool)> {
    match report {
        HostReport::Started {
            robot,
            incarnation,
            pid,
        } => {
            started.push((host, *pid, *robot, *incarnation));
            None
        }
        HostReport::Exited {
            robot,
            pid,
            how,
            ordered,
        } => {
            ended.insert((host, *pid), (how.clone(), *ordered));
            Some((*robot, how.clone(), *ordered))
        }
        _ => None,
    }
}
