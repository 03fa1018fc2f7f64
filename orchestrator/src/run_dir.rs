//! The run directory (DESIGN section 7): naming, `config.toml`, `metrics.json` and the plots
//! drawn from `trajectory.csv`.
//!
//! A run directory is checked once, when it is claimed (`safe_fs::OutDir`: no other user owns
//! it, may write it, or could swap any directory on the way to it), and from then on written
//! only through the handle opened at that check, so a path swapped afterwards changes
//! nothing. The world and robot processes reopen it by path and refuse any directory but the
//! one checked (`--out-id`).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use anyhow::Context;
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::{self, DirRefused, Open, OutDir};

use crate::error::{SwarmError, SwarmResult};

use swarmrt_analysis::plot::trajectory::{write_side_view_plots, write_trajectory_plots};

/// Checks and opens the directory `path` given as `flag` (`--out`), creating what of it is
/// missing: every failure is the user's path to fix, so one line and exit 2.
pub fn open_out(flag: &str, path: &Path) -> SwarmResult<OutDir> {
    OutDir::create(path).map_err(|e| match DirRefused::of(&e) {
        Some(r) => SwarmError::User(format!("{flag}: {r}")),
        None => SwarmError::User(format!("{flag} {}: {e}", path.display())),
    })
}

/// Creates `runs/<scenario>-s<seed>-<time>/`, with a numeric suffix if that exists already.
pub fn default_dir(cfg: &Config) -> SwarmResult<OutDir> {
    unused_dir(
        Path::new("runs"),
        &format!(
            "{}-s{}-{}",
            cfg.scenario.name,
            cfg.scenario.seed,
            timestamp()
        ),
    )
}

/// The current UTC time as `YYYYMMDD-hhmmss`, for directory names.
pub fn timestamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let (h, m, s) = ((secs / 3600) % 24, (secs / 60) % 60, secs % 60);
    let days = secs / 86_400;
    let (y, mo, d) = civil_from_days(days as i64);
    format!("{y:04}{mo:02}{d:02}-{h:02}{m:02}{s:02}")
}

/// Creates and returns `parent/name`, or `name-1`, `name-2`, ... if that exists already, with
/// `parent` checked and created as [`open_out`] does. Each name is taken with one `mkdir`,
/// which fails if the name exists, so two commands started in the same second never get the
/// same directory (checking `exists()` first would let both see it free).
pub fn unused_dir(parent: &Path, name: &str) -> SwarmResult<OutDir> {
    let parent_dir = open_out("the output directory", parent)?;
    parent_dir.create_unused_subdir(name).map_err(|e| {
        SwarmError::User(format!(
            "cannot create a directory in {}: {e}",
            parent.display()
        ))
    })
}

/// The lock file a run holds in its directory.
pub const LOCK_FILE: &str = ".lock";

/// The mark swarm leaves in every run directory it claims ([`claim`], a sweep's runs): only a
/// directory holding it is one `--force` may clear.
pub const MARK_FILE: &str = ".swarmrt-run";

/// What [`MARK_FILE`] starts with; the version of swarm that wrote it follows.
const MARK_TEXT: &str = "swarmrt run directory";

/// The files every run writes (or may: `radio.csv`, the side view, `hosts.toml`) at the top of
/// its directory; `--force` removes these, those the mark lists ([`note_written`]), their
/// `.tmp` files, and the run's own `storage/` and `config/`, and nothing else.
const RUN_FILES: [&str; 13] = [
    LOCK_FILE,
    MARK_FILE,
    "config.toml",
    "hosts.toml",
    "metrics.json",
    METRICS_ROOM,
    "trajectory.csv",
    "events.jsonl",
    "radio.csv",
    "trajectory.svg",
    "trajectory.png",
    "trajectory_side.svg",
    "trajectory_side.png",
];

/// The line of the mark that names a further file the run wrote (a behaviour's table).
const WROTE: &str = "wrote ";

/// Marks `dir` as a run directory swarm wrote ([`MARK_FILE`], never through a link planted
/// at its name: that is refused). Call it holding the directory's lock.
pub fn mark(dir: &OutDir) -> std::io::Result<()> {
    dir.write(
        MARK_FILE,
        format!("{MARK_TEXT} (swarmrt {})\n", env!("CARGO_PKG_VERSION")),
    )
}

/// Adds `names` (files of the run's directory beyond [`RUN_FILES`], such as a behaviour's
/// tables and plots) to the mark, so a later `--force` knows them as swarm's.
pub fn note_written(dir: &OutDir, names: &[String]) -> std::io::Result<()> {
    let mut text = format!("{MARK_TEXT} (swarmrt {})\n", env!("CARGO_PKG_VERSION"));
    for n in names {
        text.push_str(&format!("{WROTE}{n}\n"));
    }
    dir.write_replace(MARK_FILE, text)
}

/// [`mark`] for [`claim`]: a link at the mark's name is the user's to remove (a user error).
fn mark_claimed(dir: &OutDir) -> SwarmResult<()> {
    mark(dir).map_err(|e| {
        if safe_fs::is_symlink_refusal(&e) {
            SwarmError::User(format!("--out {}: {e}", dir.path().display()))
        } else {
            SwarmError::User(format!(
                "--out {}: cannot write {MARK_FILE}: {e}",
                dir.path().display()
            ))
        }
    })
}

/// The mark's text if `dir` holds swarm's [`MARK_FILE`] (a regular file starting with its
/// text; a link at its name is no mark).
fn read_mark(dir: &OutDir) -> Option<String> {
    let mut text = String::new();
    dir.file(MARK_FILE, Open::Read)
        .ok()?
        .take(1 << 20)
        .read_to_string(&mut text)
        .ok()?;
    text.starts_with(MARK_TEXT).then_some(text)
}

/// Whether `dir` holds swarm's [`MARK_FILE`].
pub fn is_marked(dir: &OutDir) -> bool {
    read_mark(dir).is_some()
}

/// A run's hold on its directory: an exclusive `flock` on `DIR/.lock`, taken before anything
/// is written and released when this is dropped, or by the kernel when the process dies (a
/// crashed orchestrator leaves no stale lock; the file stays, unlocked). The descriptor is
/// close-on-exec, so the world and robot processes do not inherit it.
#[derive(Debug)]
pub struct DirLock {
    file: std::fs::File,
}

impl DirLock {
    /// Writes this process's pid into the lock file, for the message a refused run prints
    /// (informative only: the lock is the `flock`). Done once a run has claimed the
    /// directory, so a refused run leaves every byte of the directory as it was.
    fn note_holder(&mut self) {
        let _ = self
            .file
            .set_len(0)
            .and_then(|()| (&self.file).write_all(format!("{}\n", std::process::id()).as_bytes()));
    }
}

/// The subdirectory of a run directory that holds the robots' stable storage (their
/// persistent Raft state, `consensus.storage`).
pub const STORAGE_DIR: &str = "storage";
/// The run's iceoryx2 config, where iceoryx2's tools look for it from the run directory
/// (`config/iceoryx2.toml`).
pub const IPC_CONFIG: &str = "config/iceoryx2.toml";
/// The subdirectory holding [`IPC_CONFIG`].
pub const IPC_CONFIG_DIR: &str = "config";

/// Whether `sub/name` is a file swarm writes in the run's subdirectory `sub`.
fn swarm_wrote_in(sub: &str, name: &str) -> bool {
    let name = name.strip_suffix(".tmp").unwrap_or(name);
    match sub {
        STORAGE_DIR => name
            .strip_prefix("raft-")
            .and_then(|n| n.strip_suffix(".state"))
            .is_some_and(|id| !id.is_empty() && id.bytes().all(|b| b.is_ascii_digit())),
        IPC_CONFIG_DIR => name == "iceoryx2.toml",
        _ => false,
    }
}

/// Claims `dir` for a run: takes its lock, then looks at what it holds. In this order two
/// runs started at the same instant cannot both pass: whoever takes the lock second is
/// refused, whether or not the first has written anything yet.
///
/// - locked by another run: refused, `--force` or not (a user error naming the directory);
/// - holding anything but the lock file and swarm's [`MARK_FILE`]: refused unless `force`;
/// - with `force`: the earlier run's files are removed first (the lock and the mark are
///   kept). Only a run directory swarm wrote is cleared, and only of what swarm wrote: it
///   must hold its [`MARK_FILE`], and nothing but [`RUN_FILES`], the files the mark lists,
///   and its own [`STORAGE_DIR`] and `config/` holding only swarm's files; anything else is
///   refused and nothing is removed, so `--force --out ~` cannot wipe a home directory, a
///   sweep, or a user's notes beside a run.
///
/// A directory claimed is marked ([`mark`]) before this returns.
pub fn claim(dir: &OutDir, force: bool) -> SwarmResult<DirLock> {
    let mut lock = lock(dir)?;
    let shown = dir.path().display();
    let listed = dir
        .entries()
        .map_err(|e| SwarmError::User(format!("--out {shown}: cannot list it: {e}")))?;
    let held: Vec<safe_fs::Entry> = listed
        .into_iter()
        .filter(|e| e.name != LOCK_FILE && e.name != MARK_FILE)
        .collect();
    if held.is_empty() {
        mark_claimed(dir)?;
        lock.note_holder();
        return Ok(lock);
    }
    let names = held
        .iter()
        .take(3)
        .map(|e| e.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let more = if held.len() > 3 { ", ..." } else { "" };
    if !force {
        return Err(SwarmError::User(format!(
            "--out {shown}: already holds files ({names}{more}); choose another directory, \
             or pass --force to remove them and run there"
        )));
    }
    let Some(mark) = read_mark(dir) else {
        return Err(SwarmError::User(format!(
            "--out {shown}: --force replaces only a run directory swarm wrote, and swarm did \
             not write this one (it has no {MARK_FILE} mark; it holds {names}{more}); nothing \
             was removed; choose another directory"
        )));
    };
    let listed: Vec<&str> = mark.lines().filter_map(|l| l.strip_prefix(WROTE)).collect();
    let ours = |name: &str| {
        let base = name.strip_suffix(".tmp").unwrap_or(name);
        RUN_FILES.contains(&base) || listed.contains(&base)
    };
    for e in &held {
        let foreign = if e.is_dir {
            if e.name == STORAGE_DIR || e.name == IPC_CONFIG_DIR {
                let sub = dir.subdir(&e.name).map_err(anyhow::Error::from)?;
                sub.entries()
                    .map_err(anyhow::Error::from)?
                    .into_iter()
                    .find(|f| f.is_dir || !swarm_wrote_in(&e.name, &f.name))
                    .map(|f| format!("{}/{}", e.name, f.name))
            } else {
                Some(format!("{}/", e.name))
            }
        } else {
            (!ours(&e.name)).then(|| e.name.clone())
        };
        if let Some(what) = foreign {
            return Err(SwarmError::User(format!(
                "--out {shown}: --force replaces only what an earlier run wrote, and this \
                 holds {what}, which swarm did not write; nothing was removed; move it or \
                 choose another directory"
            )));
        }
    }
    for e in &held {
        if e.is_dir {
            dir.remove_dir_all(&e.name)
        } else {
            dir.remove_file(&e.name)
        }
        .with_context(|| format!("--force: cannot remove {}", dir.join(&e.name).display()))?;
    }
    // At the default log level: the user asked to lose data, so say what went.
    tracing::warn!(
        "--force: removed the earlier run's {} files from {shown} ({names}{more})",
        held.len()
    );
    mark_claimed(dir)?;
    lock.note_holder();
    Ok(lock)
}

/// Takes `dir`'s lock (see [`claim`]), without looking at what it holds; a user error naming
/// the directory if another run holds it, or if its lock file is a symbolic link (refused,
/// never followed: the file it points to is neither locked nor written).
pub fn lock(dir: &OutDir) -> SwarmResult<DirLock> {
    let shown = dir.path().display();
    let file = match dir.file(LOCK_FILE, Open::ReadWrite) {
        Ok(f) => f,
        Err(e) if safe_fs::is_symlink_refusal(&e) => {
            return Err(SwarmError::User(format!("--out {shown}: {e}")));
        }
        Err(e) => {
            return Err(SwarmError::User(format!(
                "--out {shown}: cannot open its lock file {}: {e}",
                dir.join(LOCK_FILE).display()
            )));
        }
    };
    let mut file = file;
    // std's `try_lock` is `flock(LOCK_EX | LOCK_NB)` on Linux: the kernel drops it with the
    // last descriptor, so a crashed run leaves no stale lock.
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = (&mut file).take(64).read_to_string(&mut holder);
            let pid = holder
                .trim()
                .parse::<u32>()
                .map(|p| format!(" (pid {p})"))
                .unwrap_or_default();
            return Err(SwarmError::User(format!(
                "--out {shown}: another run is using this directory{pid}; wait for it to end \
                 or choose another directory (--force does not override this)"
            )));
        }
        Err(std::fs::TryLockError::Error(e)) => {
            return Err(SwarmError::User(format!(
                "--out {shown}: cannot lock {}: {e}",
                dir.join(LOCK_FILE).display()
            )));
        }
    }
    Ok(DirLock { file })
}

/// Days since 1970-01-01 to (year, month, day), proleptic Gregorian (H. Hinnant's algorithm).
pub fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + (m <= 2) as i64, m, d)
}

/// Writes the resolved config (seed included); returns its path, for the processes to read.
pub fn prepare(dir: &OutDir, cfg: &Config) -> anyhow::Result<PathBuf> {
    dir.write("config.toml", cfg.to_toml())
        .with_context(|| format!("cannot write {}", dir.join("config.toml").display()))?;
    Ok(dir.join("config.toml"))
}

/// The space a run keeps for its `metrics.json` (see [`reserve_metrics_room`]).
pub const METRICS_ROOM: &str = ".metrics-room";

/// Sets aside room for `metrics.json` before the run writes its records: a file of zeros
/// about the size a run of `robots` needs (measured: 2.9 kB for 9 robots, 16 kB for 100),
/// which [`write_metrics`] deletes just before it writes. A run that fills the disk can still
/// say that it failed. Best effort: without room even for this, the run goes on.
pub fn reserve_metrics_room(dir: &OutDir, robots: u32) {
    let len = 8 * 1024 + 256 * robots as usize;
    if let Err(e) = dir.write(METRICS_ROOM, vec![0u8; len]) {
        if !safe_fs::is_symlink_refusal(&e) {
            let _ = dir.remove_file(METRICS_ROOM);
        }
        tracing::warn!("cannot set aside room for metrics.json: {e}");
    }
}

/// Writes `text` (`swarm run`'s `Metrics::to_json`) as `metrics.json`, atomically
/// (`metrics.json.tmp` + rename): never a truncated file.
/// Frees the room [`reserve_metrics_room`] set aside first. If the write fails (a full disk)
/// the temporary file is removed rather than left half written. A symbolic link at either
/// name is refused, never followed.
pub fn write_metrics(dir: &OutDir, text: String) -> anyhow::Result<()> {
    if dir.stat(METRICS_ROOM).is_some_and(|e| !e.is_symlink) {
        let _ = dir.remove_file(METRICS_ROOM);
    }
    dir.write_replace("metrics.json", text)
        .with_context(|| format!("cannot write {}", dir.join("metrics.json").display()))
}

/// Draws `trajectory.svg` and `trajectory.png` from the recorded trajectory (written through
/// the directory's handle, refusing a link planted at their names, see
/// `swarmrt_analysis::plot::write_svg_png`).
pub fn write_plots(dir: &OutDir, cfg: &Config) -> anyhow::Result<()> {
    let tracks = swarmrt_analysis::run_dir::read_tracks(dir.path())?;
    write_trajectory_plots(cfg, &tracks, dir, "trajectory")?;
    if cfg.robots.aerial.is_some() {
        let side = swarmrt_analysis::run_dir::read_side_tracks(dir.path())?;
        write_side_view_plots(cfg, &side, dir, "trajectory_side")?;
    }
    Ok(())
}

/// After the world process died, cuts `trajectory.csv` back to its last complete tick (all
/// `robots` rows), and `events.jsonl` and `radio.csv` (when the run records it) to whole
/// lines of ticks up to it. The world writes each
/// tick with one `write_all`, but the kernel may cut a large write short when a fatal signal
/// arrives, so the records are made whole here rather than trusted. Returns the last tick.
pub fn trim_torn_records(dir: &OutDir, robots: usize) -> anyhow::Result<Option<u64>> {
    let text = dir
        .read("trajectory.csv")
        .with_context(|| format!("{}", dir.join("trajectory.csv").display()))?;
    let mut keep = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let whole = String::from_utf8_lossy(&text[..keep]).into_owned();
    let tick_of = |l: &str| l.split(',').next().and_then(|t| t.parse::<u64>().ok());
    let rows: Vec<&str> = whole.lines().skip(1).collect();
    let mut last = rows.last().and_then(|l| tick_of(l));
    if let Some(t) = last {
        let in_last = rows
            .iter()
            .rev()
            .take_while(|l| tick_of(l) == Some(t))
            .count();
        if in_last < robots {
            // Drop the torn tick's rows.
            let cut: usize = rows.iter().rev().take(in_last).map(|l| l.len() + 1).sum();
            keep -= cut;
            last = rows.iter().rev().nth(in_last).and_then(|l| tick_of(l));
        }
    }
    truncate(dir, "trajectory.csv", keep as u64)?;

    let text = read_if_any(dir, "events.jsonl")?
        .map(|b| String::from_utf8_lossy(&b).into_owned())
        .unwrap_or_default();
    let mut kept = 0;
    for line in text.split_inclusive('\n') {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else {
            break;
        };
        if !line.ends_with('\n') || v["tick"].as_u64().zip(last).is_some_and(|(t, l)| t > l) {
            break;
        }
        kept += line.len();
    }
    if kept < text.len() {
        truncate(dir, "events.jsonl", kept as u64)?;
    }

    // `radio.csv` (opt-in): the header, then rows whose first column is their tick,
    // non-decreasing; keep whole lines up to the last whole trajectory tick.
    if let Some(text) = read_if_any(dir, "radio.csv")? {
        let mut kept = 0;
        for (i, line) in text.split_inclusive(|&b| b == b'\n').enumerate() {
            if line.last() != Some(&b'\n') {
                break;
            }
            if i > 0 {
                let tick = std::str::from_utf8(line)
                    .ok()
                    .and_then(|l| l.split(',').next())
                    .and_then(|t| t.parse::<u64>().ok());
                match (tick, last) {
                    (Some(t), Some(l)) if t <= l => {}
                    _ => break,
                }
            }
            kept += line.len();
        }
        if kept < text.len() {
            truncate(dir, "radio.csv", kept as u64)?;
        }
    }
    Ok(last)
}

/// The bytes of `name`, `None` if there is no such file; a link at the name is refused.
fn read_if_any(dir: &OutDir, name: &str) -> anyhow::Result<Option<Vec<u8>>> {
    match dir.read(name) {
        Ok(b) => Ok(Some(b)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(e).with_context(|| format!("cannot trim {}", dir.join(name).display())),
    }
}

/// Cuts `name` to `len` bytes, refusing a symbolic link at its name.
fn truncate(dir: &OutDir, name: &str, len: u64) -> anyhow::Result<()> {
    dir.file(name, Open::Existing)
        .and_then(|f| f.set_len(len))
        .with_context(|| format!("cannot trim {}", dir.join(name).display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unused_dir_gives_racing_callers_distinct_new_directories() {
        let root = tempfile::tempdir().unwrap();
        let runs = root.path().join("runs");
        let dirs: Vec<PathBuf> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..8)
                .map(|_| {
                    s.spawn(|| {
                        unused_dir(&runs, "x-s1-20261123-101010")
                            .unwrap()
                            .path()
                            .to_path_buf()
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let distinct: std::collections::BTreeSet<_> = dirs.iter().collect();
        assert_eq!(distinct.len(), 8, "{dirs:?}");
        assert!(dirs.iter().all(|d| d.is_dir()));
    }

    #[test]
    fn claim_locks_refuses_and_forces() {
        let root = tempfile::tempdir().unwrap();
        let path = root.path().join("run");
        let dir = out(&path);
        let held = claim(&dir, false).unwrap();
        // Held: refused, with or without force, naming the holder.
        for force in [false, true] {
            let e = claim(&dir, force).unwrap_err().to_string();
            assert!(
                e.contains("another run is using") && e.contains(&std::process::id().to_string()),
                "{e}"
            );
        }
        assert!(is_marked(&dir), "a claimed directory is marked");
        std::fs::write(path.join("config.toml"), "x").unwrap();
        drop(held);
        let e = claim(&dir, false).unwrap_err().to_string();
        assert!(e.contains("config.toml") && e.contains("--force"), "{e}");
        let _again = claim(&dir, true).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(&path)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(
            left,
            [LOCK_FILE, MARK_FILE],
            "only the lock and the mark are left"
        );
        assert!(is_marked(&dir));
        // Not a run directory: --force does not clear it.
        let other = root.path().join("home");
        std::fs::create_dir_all(other.join("sub")).unwrap();
        std::fs::write(other.join("config.toml"), "x").unwrap();
        let e = claim(&out(&other), true).unwrap_err().to_string();
        assert!(e.contains("only a run directory"), "{e}");
        assert!(other.join("config.toml").exists() && other.join("sub").exists());
    }

    #[test]
    fn force_clears_only_a_directory_swarm_marked() {
        let root = tempfile::tempdir().unwrap();
        // A config.toml swarm did not write (no mark): refused, nothing removed.
        let foreign = root.path().join("foreign");
        std::fs::create_dir(&foreign).unwrap();
        std::fs::write(foreign.join("config.toml"), "mine").unwrap();
        std::fs::write(foreign.join("notes.txt"), "mine too").unwrap();
        let e = claim(&out(&foreign), true).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "--out {}: --force replaces only a run directory swarm wrote, and swarm did not \
                 write this one (it has no .swarmrt-run mark; it holds config.toml, notes.txt); \
                 nothing was removed; choose another directory",
                foreign.display()
            )
        );
        assert_eq!(std::fs::read(foreign.join("config.toml")).unwrap(), b"mine");
        assert!(foreign.join("notes.txt").exists() && !foreign.join(MARK_FILE).exists());
        // A mark that is a link, or holds other text, is no mark.
        let victim = root.path().join("victim");
        std::fs::write(&victim, format!("{MARK_TEXT} (forged)\n")).unwrap();
        std::os::unix::fs::symlink(&victim, foreign.join(MARK_FILE)).unwrap();
        assert!(!is_marked(&out(&foreign)));
        assert!(claim(&out(&foreign), true).is_err());
        std::fs::remove_file(foreign.join(MARK_FILE)).unwrap();
        std::fs::write(foreign.join(MARK_FILE), "something else\n").unwrap();
        assert!(!is_marked(&out(&foreign)));
        assert!(claim(&out(&foreign), true).is_err());
        assert!(foreign.join("config.toml").exists());

        // Marked, but holding a subdirectory that is not its own: refused too.
        let sub = root.path().join("sub");
        drop(claim(&out(&sub), false).unwrap());
        std::fs::create_dir_all(sub.join("photos")).unwrap();
        std::fs::create_dir_all(sub.join(STORAGE_DIR)).unwrap();
        let e = claim(&out(&sub), true).unwrap_err().to_string();
        assert!(
            e.contains("holds photos/") && e.contains("nothing was removed"),
            "{e}"
        );
        assert!(sub.join("photos").is_dir() && sub.join(STORAGE_DIR).is_dir());
        // Marked, but holding a file swarm never wrote beside the run's own: refused too,
        // and so is a stranger inside storage/.
        std::fs::remove_dir_all(sub.join("photos")).unwrap();
        std::fs::write(sub.join("notes.txt"), "mine").unwrap();
        std::fs::write(sub.join("trajectory.csv"), "x").unwrap();
        let e = claim(&out(&sub), true).unwrap_err().to_string();
        assert!(
            e.contains("holds notes.txt, which swarm did not write"),
            "{e}"
        );
        std::fs::remove_file(sub.join("notes.txt")).unwrap();
        std::fs::write(sub.join(STORAGE_DIR).join("thesis.tex"), "mine").unwrap();
        let e = claim(&out(&sub), true).unwrap_err().to_string();
        assert!(e.contains("holds storage/thesis.tex"), "{e}");
        assert!(sub.join("trajectory.csv").exists() && sub.join("storage/thesis.tex").exists());
        // A behaviour's table the mark lists is swarm's.
        std::fs::remove_file(sub.join(STORAGE_DIR).join("thesis.tex")).unwrap();
        std::fs::write(sub.join("chain.csv"), "x").unwrap();
        assert!(claim(&out(&sub), true).is_err());
        note_written(&out(&sub), &["chain.csv".to_string()]).unwrap();
        drop(claim(&out(&sub), true).unwrap());
        assert!(!sub.join("chain.csv").exists() && !sub.join("trajectory.csv").exists());

        // Marked with its own storage/ and config/: cleared, a link inside removed as a link.
        let run = root.path().join("run");
        drop(claim(&out(&run), false).unwrap());
        std::fs::create_dir_all(run.join("storage")).unwrap();
        std::fs::write(run.join("storage/raft-0.state"), "x").unwrap();
        std::fs::write(run.join("config.toml"), "x").unwrap();
        std::os::unix::fs::symlink(&victim, run.join("trajectory.csv")).unwrap();
        drop(claim(&out(&run), true).unwrap());
        assert!(!run.join("storage").exists() && !run.join("config.toml").exists());
        assert!(std::fs::symlink_metadata(run.join("trajectory.csv")).is_err());
        assert!(
            std::fs::read_to_string(&victim)
                .unwrap()
                .starts_with(MARK_TEXT)
        );
        // An empty directory holding only a mark and a lock is free without --force.
        drop(claim(&out(&run), false).unwrap());
    }

    /// The run directory at `path`, checked and opened.
    fn out(path: &Path) -> OutDir {
        open_out("--out", path).unwrap()
    }

    /// A symbolic link planted at `name` in a fresh directory, pointing at a file outside
    /// holding "keep"; returns (the directory, the file outside, the link).
    fn planted(root: &Path, name: &str) -> (PathBuf, PathBuf, PathBuf) {
        let dir = root.join(format!("run-{}", name.trim_start_matches('.')));
        std::fs::create_dir_all(&dir).unwrap();
        let victim = root.join(format!("victim-{}", name.trim_start_matches('.')));
        std::fs::write(&victim, "keep").unwrap();
        let link = dir.join(name);
        std::os::unix::fs::symlink(&victim, &link).unwrap();
        (dir, victim, link)
    }

    #[test]
    fn links_planted_in_a_run_directory_are_refused_never_followed() {
        let root = tempfile::tempdir().unwrap();
        let refused = |link: &Path| {
            format!(
                "{} is a symbolic link; refusing to follow it",
                link.display()
            )
        };

        // The lock: refused as a user error, before anything is written; not locked either.
        let (dir, victim, link) = planted(root.path(), LOCK_FILE);
        for force in [false, true] {
            let e = claim(&out(&dir), force).unwrap_err();
            assert!(matches!(e, SwarmError::User(_)), "{e}");
            assert_eq!(
                e.to_string(),
                format!("--out {}: {}", dir.display(), refused(&link))
            );
        }
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "nothing written"
        );
        let f = std::fs::File::open(&victim).unwrap();
        assert!(f.try_lock().is_ok(), "the file outside was never locked");

        // The mark.
        let (dir, victim, link) = planted(root.path(), MARK_FILE);
        let e = claim(&out(&dir), false).unwrap_err();
        assert!(matches!(e, SwarmError::User(_)), "{e}");
        assert!(e.to_string().ends_with(&refused(&link)), "{e}");
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");

        let cfg = Config::from_toml_str(
            "links.toml",
            "[scenario]\nname = \"links\"\nticks = 3\n[map]\nbounds = [0.0, 0.0, 10.0, 10.0]\n\
             goal = { x = 3.5, y = 3.0, radius = 1.0 }\n[robots]\ncount = 2\n",
            &[],
        )
        .unwrap();
        // config.toml.
        let (dir, victim, link) = planted(root.path(), "config.toml");
        let e = format!("{:#}", prepare(&out(&dir), &cfg).unwrap_err());
        assert!(e.ends_with(&refused(&link)), "{e}");
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");

        // metrics.json, its temporary file and the room set aside for it.
        for name in ["metrics.json", "metrics.json.tmp", METRICS_ROOM] {
            let (dir, victim, link) = planted(root.path(), name);
            reserve_metrics_room(&out(&dir), 2);
            if name == METRICS_ROOM {
                assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
            } else {
                let e = format!(
                    "{:#}",
                    write_metrics(&out(&dir), "{}\n".to_string()).unwrap_err()
                );
                assert!(e.ends_with(&refused(&link)), "{e}");
            }
            assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep", "{name}");
        }

        // Trimming torn records.
        let (dir, victim, link) = planted(root.path(), "events.jsonl");
        std::fs::write(
            dir.join("trajectory.csv"),
            "tick,id,x,y,theta,v,omega,lidar,state\n0,0,1,1,0,0,0,1,active\n",
        )
        .unwrap();
        let e = format!("{:#}", trim_torn_records(&out(&dir), 1).unwrap_err());
        assert!(e.ends_with(&refused(&link)), "{e}");
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");

        // The plots.
        for name in ["trajectory.svg", "trajectory.png"] {
            let (dir, victim, link) = planted(root.path(), name);
            std::fs::write(
                dir.join("trajectory.csv"),
                "tick,id,x,y,theta,v,omega,lidar,state\n0,0,1,1,0,0,0,1,active\n\
                 0,1,2,2,0,0,0,1,active\n",
            )
            .unwrap();
            let e = format!("{:#}", write_plots(&out(&dir), &cfg).unwrap_err());
            assert!(e.ends_with(&refused(&link)), "{e}");
            assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep", "{name}");
            let left: Vec<_> = std::fs::read_dir(&dir)
                .unwrap()
                .map(|e| e.unwrap().file_name())
                .filter(|n| n.to_string_lossy().ends_with(".tmp"))
                .collect();
            assert!(left.is_empty(), "no temporary left: {left:?}");
        }
    }

    #[test]
    fn civil_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(20_779), (2026, 11, 22));
    }

    #[test]
    fn torn_records_are_cut_back_to_the_last_whole_tick() {
        let dir = tempfile::tempdir().unwrap();
        let handle = out(dir.path());
        let header = "tick,id,x,y,theta,v,omega,lidar,state\n";
        let rows = "0,0,1,1,0,0,0,1,active\n0,1,2,2,0,0,0,1,active\n\
                    1,0,1,1,0,0,0,1,active\n1,1,2,2,0,0,0,1,active\n\
                    2,0,1,1,0,0,0,1,active\n2,1,2,";
        std::fs::write(dir.path().join("trajectory.csv"), format!("{header}{rows}")).unwrap();
        std::fs::write(
            dir.path().join("events.jsonl"),
            "{\"event\":\"reached\",\"tick\":1,\"robot\":0}\n\
             {\"event\":\"reached\",\"tick\":2,\"robot\":1}\n{\"event\":\"rea",
        )
        .unwrap();
        let radio = "tick,sent_tick,from,to,bytes,outcome\n0,0,0,1,4,loss\n\
                     1,0,1,0,4,delivered\n1,1,0,,4,capacity\n2,1,0,1,4,delivered\n2,2,1,0,4,lo";
        std::fs::write(dir.path().join("radio.csv"), radio).unwrap();
        assert_eq!(trim_torn_records(&handle, 2).unwrap(), Some(1));
        let kept = std::fs::read_to_string(dir.path().join("radio.csv")).unwrap();
        assert_eq!(
            kept,
            "tick,sent_tick,from,to,bytes,outcome\n0,0,0,1,4,loss\n\
             1,0,1,0,4,delivered\n1,1,0,,4,capacity\n"
        );
        let csv = std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap();
        assert!(csv.ends_with("1,1,2,2,0,0,0,1,active\n"), "{csv}");
        assert_eq!(csv.lines().count(), 5);
        let ev = std::fs::read_to_string(dir.path().join("events.jsonl")).unwrap();
        assert_eq!(ev, "{\"event\":\"reached\",\"tick\":1,\"robot\":0}\n");
        // Whole records are left alone.
        assert_eq!(trim_torn_records(&handle, 2).unwrap(), Some(1));
        assert_eq!(
            std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap(),
            csv
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join("radio.csv")).unwrap(),
            kept
        );
        // A torn header alone is cut to nothing; a run without radio.csv has none made.
        std::fs::write(dir.path().join("radio.csv"), "tick,sent_ti").unwrap();
        assert_eq!(trim_torn_records(&handle, 2).unwrap(), Some(1));
        assert_eq!(
            std::fs::read_to_string(dir.path().join("radio.csv")).unwrap(),
            ""
        );
        std::fs::remove_file(dir.path().join("radio.csv")).unwrap();
        assert_eq!(trim_torn_records(&handle, 2).unwrap(), Some(1));
        assert!(!dir.path().join("radio.csv").exists());
    }
}
