//! Commands travel in groups of [`ipc::COMMAND_GROUP`] robot ids, one service each: a robot
//! publishes in its own group, and one drain of the world's subscribers takes every group's
//! commands, whichever groups they are in.

use iceoryx2::prelude::PortFactory;
use swarmrt_ipc as ipc;
use swarmrt_ipc::cleanup;
use swarmrt_protocol::Command;
use swarmrt_protocol::services::RunServices;

#[test]
fn one_drain_takes_the_commands_of_every_group() {
    let run_id = format!("{:012x}", std::process::id() as u64 * 7919 + 0x6c0);
    let run = RunServices::new(&run_id);
    let world = ipc::node(&run, "groups-world").unwrap();
    // 70 robots: groups 0 (ids 0..32), 1 (32..64) and 2 (64..70).
    let services = ipc::create_services(&world, &run, 0..70, 0, 0).unwrap();
    assert_eq!(services.commands.len(), 3);
    assert_eq!(ipc::command_groups(&(0..70)), 0..3);
    assert_eq!(ipc::command_groups(&(40..64)), 1..2, "a host's robots");
    assert_eq!(ipc::command_groups(&(5..5)), 0..0);
    let ports = ipc::WorldPorts::open(&services, 70, 0).unwrap();

    let robot = ipc::node(&run, "groups-robots").unwrap();
    let ids = [0u32, 31, 32, 69, 65];
    let robots: Vec<ipc::RobotPorts> = ids
        .iter()
        .map(|&id| ipc::RobotPorts::open_listening(&robot, &run, id).unwrap())
        .collect();
    for (&id, ports) in ids.iter().zip(&robots) {
        ports.send(Command::act(id, 7)).unwrap();
    }
    // A command in the first group once the drain has left it (groups are drained in
    // order: 0 and 31, then 32) is taken by the next drain.
    let mut got = Vec::new();
    while let Some(sample) = ports.commands.receive().unwrap() {
        got.push(sample.payload().robot);
        if got.len() == 3 {
            robots[1].send(Command::act(31, 8)).unwrap();
        }
    }
    got.sort();
    assert_eq!(got, vec![0, 31, 32, 65, 69]);
    let mut again = Vec::new();
    while let Some(sample) = ports.commands.receive().unwrap() {
        again.push((sample.payload().robot, sample.payload().tick));
    }
    assert_eq!(again, vec![(31, 8)]);

    // The group services carry the robots' names; the event stays one per run.
    let name = |s: &ipc::CommandService| s.name().to_string();
    assert_eq!(name(&services.commands[2]), run.robot_commands(69));
    assert_eq!(services.commands_event.name().to_string(), run.commands());

    drop(robots);
    drop(ports);
    drop(services);
    drop(robot);
    drop(world);
    cleanup::remove_run(&run_id);
    assert!(cleanup::leftovers(&run_id).is_empty());
}
