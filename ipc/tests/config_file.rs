//! The run's iceoryx2 config file is written into the run directory like every other file
//! there: never through a symbolic link planted in its place (docs/security.md).

use std::os::unix::fs::symlink;

use swarmrt_protocol::services::RunServices;

#[test]
fn the_ipc_config_is_written_and_a_planted_link_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let run = RunServices::new("0123456789ab");
    let path = tmp.path().join("config/iceoryx2.toml");
    swarmrt_ipc::write_config_file(&run, &path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("0123456789ab"), "{text}");

    // A link at the file: refused, its target untouched.
    let victim = tmp.path().join("victim");
    std::fs::write(&victim, "keep").unwrap();
    std::fs::remove_file(&path).unwrap();
    symlink(&victim, &path).unwrap();
    let err = swarmrt_ipc::write_config_file(&run, &path).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{} is a symbolic link; refusing to follow it",
            path.display()
        )
    );
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");

    // A link at its directory: refused too.
    let elsewhere = tmp.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    let linked = tmp.path().join("linked");
    symlink(&elsewhere, &linked).unwrap();
    let err = swarmrt_ipc::write_config_file(&run, &linked.join("iceoryx2.toml")).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{} is a symbolic link; refusing to follow it",
            linked.display()
        )
    );
    assert!(std::fs::read_dir(&elsewhere).unwrap().next().is_none());
}
