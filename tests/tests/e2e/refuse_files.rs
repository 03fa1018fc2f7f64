//! Files that refuse what is not theirs (issue 32): a symbolic link planted in a run directory
//! is refused, never followed; `--force` clears only a directory swarm marked as its own; a
//! robot whose Raft storage is corrupt (not merely torn at its end) refuses to start.

use std::collections::BTreeMap;
use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, SystemTime};

use swarmrt_tests::{assert_ok, bin_dir, metrics, swarm, wait_with_watchdog, workspace};

const LIMIT: Duration = Duration::from_secs(180);

/// `swarm run configs/goto_simple.toml --ticks 30 --out DIR extra...`.
fn short_run(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        "configs/goto_simple.toml",
        "--ticks",
        "30",
        "--out",
        dir.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    swarm(&args, LIMIT)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts a user error: exit 2 and one line holding `says`.
fn assert_refused(out: &Output, says: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    assert!(err.contains(says), "says {says:?}: {err}");
    assert!(out.stdout.is_empty(), "no run directory printed");
}

/// Every entry of a directory tree (links as links) with its bytes or link target.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let rel = e.path().strip_prefix(dir).unwrap().display().to_string();
            let t = e.file_type().unwrap();
            if t.is_dir() {
                files.insert(format!("{rel}/"), Vec::new());
                todo.push(e.path());
            } else if t.is_symlink() {
                let to = std::fs::read_link(e.path()).unwrap();
                files.insert(format!("{rel} ->"), to.display().to_string().into_bytes());
            } else {
                files.insert(rel, std::fs::read(e.path()).unwrap());
            }
        }
    }
    files
}

/// A file's bytes and modification time.
fn content_and_mtime(path: &Path) -> (Vec<u8>, SystemTime) {
    (
        std::fs::read(path).unwrap(),
        std::fs::metadata(path).unwrap().modified().unwrap(),
    )
}

#[test]
fn a_lock_file_planted_as_a_link_is_refused_and_its_target_untouched() {
    let tmp = tempfile::tempdir().unwrap();
    let victim = tmp.path().join("precious.txt");
    std::fs::write(&victim, "do not truncate me\n").unwrap();
    // An old mtime, so a write in the same second would still show.
    let old = SystemTime::UNIX_EPOCH + Duration::from_secs(1_000_000_000);
    std::fs::File::options()
        .write(true)
        .open(&victim)
        .unwrap()
        .set_modified(old)
        .unwrap();
    let before = content_and_mtime(&victim);
    let dir = tmp.path().join("run");
    std::fs::create_dir(&dir).unwrap();
    let link = dir.join(".lock");
    symlink(&victim, &link).unwrap();

    for extra in [&[][..], &["--force"][..], &["--in-process", "--force"][..]] {
        let out = short_run(&dir, extra);
        assert_refused(
            &out,
            &format!(
                "--out {}: {} is a symbolic link; refusing to follow it",
                dir.display(),
                link.display()
            ),
        );
        assert_eq!(content_and_mtime(&victim), before, "{extra:?}");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "nothing written beside the link ({extra:?})"
        );
        assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
    }
    // Once the link is gone the directory is an ordinary empty one.
    std::fs::remove_file(&link).unwrap();
    assert_ok(&short_run(&dir, &["--in-process"]));
    assert_eq!(content_and_mtime(&victim), before);
}

#[test]
fn force_clears_only_a_directory_swarm_marked() {
    let tmp = tempfile::tempdir().unwrap();
    // A directory holding a config.toml swarm did not write: refused, nothing removed.
    let foreign = tmp.path().join("mine");
    std::fs::create_dir_all(foreign.join("storage")).unwrap();
    std::fs::write(foreign.join("config.toml"), "# my own notes\n").unwrap();
    std::fs::write(foreign.join("trajectory.csv"), "not swarm's\n").unwrap();
    std::fs::write(foreign.join("storage/raft-0.state"), "keep").unwrap();
    let before = snapshot(&foreign);
    for extra in [&["--force"][..], &["--in-process", "--force"][..]] {
        let out = short_run(&foreign, extra);
        assert_refused(
            &out,
            &format!(
                "--out {}: --force replaces only a run directory swarm wrote, and swarm did \
                 not write this one (it has no .swarmrt-run mark; it holds config.toml, \
                 storage, trajectory.csv); nothing was removed; choose another directory",
                foreign.display()
            ),
        );
        let mut after = snapshot(&foreign);
        // The lock file is made before the directory is looked at; nothing else changes.
        assert_eq!(after.remove(".lock"), Some(Vec::new()));
        assert_eq!(after, before, "nothing removed or written ({extra:?})");
    }

    // A real earlier run's directory is marked, and --force replaces it.
    let dir = tmp.path().join("run");
    assert_ok(&short_run(&dir, &["--seed", "3"]));
    let mark = std::fs::read_to_string(dir.join(".swarmrt-run")).unwrap();
    assert!(
        mark.starts_with("swarmrt run directory (swarmrt "),
        "{mark}"
    );
    // c0b8b90 removed every file of a marked directory, a user's own beside the run too. A
    // file swarm never wrote makes --force refuse now, and nothing goes.
    std::fs::write(dir.join("notes.csv"), "mine").unwrap();
    let before = snapshot(&dir);
    assert_refused(
        &short_run(&dir, &["--seed", "4", "--force"]),
        &format!(
            "--out {}: --force replaces only what an earlier run wrote, and this holds \
             notes.csv, which swarm did not write; nothing was removed; move it or choose \
             another directory",
            dir.display()
        ),
    );
    // A refused run writes nothing, not even its pid into the lock.
    assert_eq!(snapshot(&dir), before);
    std::fs::remove_file(dir.join("notes.csv")).unwrap();
    let out = short_run(&dir, &["--seed", "4", "--force"]);
    assert_ok(&out);
    assert_eq!(metrics(&dir)["seed"], 4);
    assert!(dir.join(".swarmrt-run").is_file(), "and the mark stays");

    // Without the mark (a run directory from before marks, or a copy), --force refuses.
    std::fs::remove_file(dir.join(".swarmrt-run")).unwrap();
    let before = snapshot(&dir);
    assert_refused(
        &short_run(&dir, &["--force"]),
        "swarm did not write this one",
    );
    assert_eq!(snapshot(&dir), before);
}

/// The records of a Raft storage file: each record's offset and length (header included).
fn records(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut at = 0;
    while at + 8 <= bytes.len() {
        let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        if at + 8 + len > bytes.len() {
            break;
        }
        out.push((at, 8 + len));
        at += 8 + len;
    }
    assert_eq!(at, bytes.len(), "whole records only");
    out
}

/// `swarm-agent` as the supervisor starts a restarted robot (incarnation 1), with its output
/// captured.
fn agent(run_dir: &Path, robot: u32) -> Output {
    let child = Command::new(bin_dir().join("swarm-agent"))
        .current_dir(workspace())
        .args(["--run-id", "5afe0f11e5", "--robot", &robot.to_string()])
        .args(["--incarnation", "1", "--slot-offset", "0", "--config"])
        .arg(run_dir.join("config.toml"))
        .arg("--storage")
        .arg(run_dir.join("storage"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm-agent starts");
    wait_with_watchdog(child, Duration::from_secs(60))
}

/// A Raft run's storage file with a flipped byte in a record that is not the last: the
/// restarted robot's process refuses to start, exit 2, one line naming the file, the record
/// and the byte; the file is left as it was for the user to look at.
#[test]
fn a_robot_with_corrupt_raft_storage_refuses_to_start() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("raft");
    assert_ok(&swarm(
        &[
            "run",
            "configs/raft_election.toml",
            "--ticks",
            "120",
            "--out",
            dir.to_str().unwrap(),
        ],
        LIMIT,
    ));
    // The robot whose file holds the most records.
    let (robot, path, recs) = (0..9u32)
        .map(|r| {
            let path: PathBuf = dir.join(format!("storage/raft-{r}.state"));
            let recs = records(&std::fs::read(&path).unwrap());
            (r, path, recs)
        })
        .max_by_key(|(_, _, recs)| recs.len())
        .unwrap();
    assert!(
        recs.len() >= 2,
        "robot {robot} saved {} records",
        recs.len()
    );
    let mut bytes = std::fs::read(&path).unwrap();
    let (offset, _) = recs[recs.len() - 2];
    bytes[offset + 8 + 1] ^= 0x20;
    std::fs::write(&path, &bytes).unwrap();

    let out = agent(&dir, robot);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(
        err,
        format!(
            "robot {robot}'s Raft storage {} is corrupt at record {} (byte {offset}): checksum \
             mismatch; refusing to start (delete the file to start the robot with no state)\n",
            path.display(),
            recs.len() - 1
        )
    );
    assert_eq!(
        std::fs::read(&path).unwrap(),
        bytes,
        "nothing cut or rewritten"
    );

    // A storage file planted as a link is refused the same way (one line, not followed).
    let victim = tmp.path().join("victim.state");
    std::fs::write(&victim, "keep").unwrap();
    std::fs::remove_file(&path).unwrap();
    symlink(&victim, &path).unwrap();
    let out = agent(&dir, robot);
    assert_ne!(out.status.code(), Some(0));
    assert!(
        stderr(&out).contains(&format!(
            "{} is a symbolic link; refusing to follow it",
            path.display()
        )),
        "{}",
        stderr(&out)
    );
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
}

/// The same through `swarm run`, as a user meets it: robot 2 is restarted at tick 60 and its
/// new process finds its storage corrupt (a wrapper flips a byte in the first of its two
/// records, then execs `swarm-agent`). The robot refuses to start, the run goes on without
/// it, names the file on stderr and records the death with its exit code 2.
#[test]
fn a_restarted_robot_with_corrupt_storage_is_a_death_the_run_names() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("raft");
    let agent = bin_dir().join("swarm-agent");
    // $0 is the agent; its arguments follow. Incarnation 1 is the restarted process.
    let wrapper = r#"inc=; st=; prev=
for a in "$@"; do
  case $prev in --incarnation) inc=$a ;; --storage) st=$a ;; esac
  prev=$a
done
if [ "$inc" = 1 ]; then printf '\377' | dd of="$st/raft-2.state" bs=1 seek=9 conv=notrunc 2>/dev/null; fi
exec "$0" "$@""#;
    let program = format!(
        "robots.programs=[{{robots=\"2\", program=[\"sh\", \"-c\", {wrapper:?}, {:?}]}}]",
        agent.display().to_string()
    );
    let out = swarm(
        &[
            "run",
            "configs/raft_election.toml",
            "--ticks",
            "160",
            "--set",
            "faults.restart=[{tick=60,robot=2,down_ticks=20}]",
            "--set",
            &program,
            "--out",
            dir.to_str().unwrap(),
        ],
        LIMIT,
    );
    let err = stderr(&out);
    let file = dir.join("storage/raft-2.state");
    assert!(
        err.lines().any(|l| l.starts_with(&format!(
            "robot 2's Raft storage {} is corrupt at record 1 (byte 0): checksum mismatch; refusing to start",
            file.display()
        ))),
        "the robot's one line reaches the user:\n{err}"
    );
    let m = metrics(&dir);
    assert_eq!(m["ticks"], 160, "the run went on: {m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 2, "{m}");
    assert_eq!(
        m["unscheduled_deaths"][0]["how"], "exited with code 2",
        "{m}"
    );
    assert_eq!(m["reproducible"], false, "{m}");
}
