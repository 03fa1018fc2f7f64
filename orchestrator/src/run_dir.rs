//! The run directory (DESIGN section 7): naming, `config.toml`, `metrics.json` and the plots
//! drawn from `trajectory.csv`.

use std::path::{Path, PathBuf};

use std::io::{Read, Write};

use anyhow::Context;
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs;

use crate::error::{SwarmError, SwarmResult};

use swarmrt_analysis::plot::trajectory::{write_side_view_plots, write_trajectory_plots};

/// Creates `runs/<scenario>-s<seed>-<time>/`, with a numeric suffix if that exists already.
pub fn default_dir(cfg: &Config) -> anyhow::Result<PathBuf> {
    unused_dir(&format!(
        "runs/{}-s{}-{}",
        cfg.scenario.name,
        cfg.scenario.seed,
        timestamp()
    ))
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

/// Creates and returns `base`, or `base-1`, `base-2`, ... if that exists already. Each name
/// is taken with one `create_dir`, which fails if the name exists, so two commands started in
/// the same second never get the same directory (checking `exists()` first would let both
/// see it free).
pub fn unused_dir(base: &str) -> anyhow::Result<PathBuf> {
    if let Some(parent) = Path::new(base)
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
    {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    let mut dir = PathBuf::from(base);
    let mut k = 1;
    loop {
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                dir = PathBuf::from(format!("{base}-{k}"));
                k += 1;
            }
            Err(e) => return Err(e).with_context(|| format!("cannot create {}", dir.display())),
        }
    }
}

/// The lock file a run holds in its directory.
pub const LOCK_FILE: &str = ".lock";

/// The mark swarm leaves in every run directory it claims ([`claim`], a sweep's runs): only a
/// directory holding it is one `--force` may clear.
pub const MARK_FILE: &str = ".swarmrt-run";

/// What [`MARK_FILE`] starts with; the version of swarm that wrote it follows.
const MARK_TEXT: &str = "swarmrt run directory";

/// Marks `dir` as a run directory swarm wrote ([`MARK_FILE`], never through a link planted
/// at its name: that is refused). Call it holding the directory's lock.
pub fn mark(dir: &Path) -> std::io::Result<()> {
    safe_fs::write_nofollow(
        &dir.join(MARK_FILE),
        format!("{MARK_TEXT} (swarmrt {})\n", env!("CARGO_PKG_VERSION")),
    )
}

/// [`mark`] for [`claim`]: a link at the mark's name is the user's to remove (a user error).
fn mark_claimed(dir: &Path) -> SwarmResult<()> {
    mark(dir).map_err(|e| {
        if safe_fs::is_symlink_refusal(&e) {
            SwarmError::User(format!("--out {}: {e}", dir.display()))
        } else {
            let path = dir.join(MARK_FILE);
            SwarmError::Internal(
                anyhow::Error::from(e).context(format!("cannot write {}", path.display())),
            )
        }
    })
}

/// Whether `dir` holds swarm's [`MARK_FILE`] (a regular file starting with its text; a link
/// at its name is no mark).
pub fn is_marked(dir: &Path) -> bool {
    let mut head = [0u8; MARK_TEXT.len()];
    safe_fs::open_nofollow(&dir.join(MARK_FILE), std::fs::OpenOptions::new().read(true))
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == *MARK_TEXT.as_bytes())
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
const IPC_CONFIG_DIR: &str = "config";

/// Claims `dir` for a run: creates it, takes its lock, then looks at what it holds. In this
/// order two runs started at the same instant cannot both pass: whoever takes the lock second
/// is refused, whether or not the first has written anything yet.
///
/// - locked by another run: refused, `--force` or not (a user error naming the directory);
/// - holding anything but the lock file and swarm's [`MARK_FILE`]: refused unless `force`;
/// - with `force`: the earlier run's files are removed first (the lock and the mark are
///   kept). Only a run directory swarm wrote is cleared: one that holds its [`MARK_FILE`] and
///   no subdirectory but its own [`STORAGE_DIR`] and `config/`, so `--force --out ~` cannot
///   wipe a home directory, a sweep, or a directory that merely holds a `config.toml`.
///
/// A directory claimed is marked ([`mark`]) before this returns.
pub fn claim(dir: &Path, force: bool) -> SwarmResult<DirLock> {
    let mut lock = lock(dir)?;
    let shown = dir.display();
    let mut held: Vec<(String, bool)> = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("cannot list {shown}"))? {
        let entry = entry.with_context(|| format!("cannot list {shown}"))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name != LOCK_FILE && name != MARK_FILE {
            // `file_type` does not follow a link: a link is removed, never what it points to.
            let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
            held.push((name, is_dir));
        }
    }
    if held.is_empty() {
        mark_claimed(dir)?;
        lock.note_holder();
        return Ok(lock);
    }
    held.sort();
    let names = held
        .iter()
        .take(3)
        .map(|(n, _)| n.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let more = if held.len() > 3 { ", ..." } else { "" };
    if !force {
        return Err(SwarmError::User(format!(
            "--out {shown}: already holds files ({names}{more}); choose another directory, \
             or pass --force to remove them and run there"
        )));
    }
    if !is_marked(dir) {
        return Err(SwarmError::User(format!(
            "--out {shown}: --force replaces only a run directory swarm wrote, and swarm did \
             not write this one (it has no {MARK_FILE} mark; it holds {names}{more}); nothing \
             was removed; choose another directory"
        )));
    }
    if let Some((sub, _)) = held
        .iter()
        .find(|(n, d)| *d && n != STORAGE_DIR && n != IPC_CONFIG_DIR)
    {
        return Err(SwarmError::User(format!(
            "--out {shown}: --force replaces only a run directory (no subdirectories but its \
             own storage/ and config/), and this holds {sub}/; nothing was removed; choose \
             another directory"
        )));
    }
    for (name, is_dir) in &held {
        let p = dir.join(name);
        if *is_dir {
            std::fs::remove_dir_all(&p)
        } else {
            std::fs::remove_file(&p)
        }
        .with_context(|| format!("--force: cannot remove {}", p.display()))?;
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

/// Creates `dir` and takes its lock (see [`claim`]), without looking at what it holds; a
/// user error naming the directory if another run holds it, or if its lock file is a
/// symbolic link (refused, never followed: the file it points to is neither locked nor
/// written).
pub fn lock(dir: &Path) -> SwarmResult<DirLock> {
    let shown = dir.display();
    if dir.exists() && !dir.is_dir() {
        return Err(SwarmError::User(format!("--out {shown}: not a directory")));
    }
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {shown}"))?;
    let path = dir.join(LOCK_FILE);
    let mut file = match safe_fs::open_rw_nofollow(&path) {
        Ok(f) => f,
        Err(e) if safe_fs::is_symlink_refusal(&e) => {
            return Err(SwarmError::User(format!("--out {shown}: {e}")));
        }
        Err(e) => {
            return Err(SwarmError::Internal(
                anyhow::Error::from(e).context(format!("cannot open {}", path.display())),
            ));
        }
    };
    if !file.metadata().is_ok_and(|m| m.is_file()) {
        return Err(SwarmError::User(format!(
            "--out {shown}: {} is not a regular file; refusing to use it as the lock",
            path.display()
        )));
    }
    // std's `try_lock` is `flock(LOCK_EX | LOCK_NB)` on Linux: the kernel drops it with the
    // last descriptor, so a crashed run leaves no stale lock.
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = file.read_to_string(&mut holder);
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
            return Err(SwarmError::Internal(
                anyhow::Error::from(e).context(format!("cannot lock {}", path.display())),
            ));
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

/// Creates the directory and writes the resolved config (seed included).
pub fn prepare(dir: &Path, cfg: &Config) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let config_path = dir.join("config.toml");
    safe_fs::write_nofollow(&config_path, cfg.to_toml())
        .with_context(|| format!("cannot write {}", config_path.display()))?;
    Ok(config_path)
}

/// The space a run keeps for its `metrics.json` (see [`reserve_metrics_room`]).
pub const METRICS_ROOM: &str = ".metrics-room";

/// Sets aside room for `metrics.json` before the run writes its records: a file of zeros
/// about the size a run of `robots` needs (measured: 2.9 kB for 9 robots, 16 kB for 100),
/// which [`write_metrics`] deletes just before it writes. A run that fills the disk can still
/// say that it failed. Best effort: without room even for this, the run goes on.
pub fn reserve_metrics_room(dir: &Path, robots: u32) {
    let len = 8 * 1024 + 256 * robots as usize;
    if let Err(e) = safe_fs::write_nofollow(&dir.join(METRICS_ROOM), vec![0u8; len]) {
        if !safe_fs::is_symlink_refusal(&e) {
            let _ = std::fs::remove_file(dir.join(METRICS_ROOM));
        }
        tracing::warn!("cannot set aside room for metrics.json: {e}");
    }
}

/// Writes `metrics.json` atomically (`metrics.json.tmp` + rename): never a truncated file.
/// Frees the room [`reserve_metrics_room`] set aside first. If the write fails (a full disk)
/// the temporary file is removed rather than left half written. A symbolic link at either
/// name is refused, never followed.
pub fn write_metrics(dir: &Path, metrics: &serde_json::Value) -> anyhow::Result<()> {
    let _ = std::fs::remove_file(dir.join(METRICS_ROOM));
    let text = serde_json::to_string_pretty(metrics)? + "\n";
    safe_fs::write_replace_nofollow(&dir.join("metrics.json"), text)
        .with_context(|| format!("cannot write {}/metrics.json", dir.display()))
}

/// Draws `trajectory.svg` and `trajectory.png` from the recorded trajectory (written without
/// following a link planted at their names, see `swarmrt_analysis::plot::write_svg_png`).
pub fn write_plots(dir: &Path, cfg: &Config) -> anyhow::Result<()> {
    let tracks = swarmrt_analysis::run_dir::read_tracks(dir)?;
    write_trajectory_plots(
        cfg,
        &tracks,
        &dir.join("trajectory.svg"),
        &dir.join("trajectory.png"),
    )?;
    if cfg.robots.aerial.is_some() {
        let side = swarmrt_analysis::run_dir::read_side_tracks(dir)?;
        write_side_view_plots(
            cfg,
            &side,
            &dir.join("trajectory_side.svg"),
            &dir.join("trajectory_side.png"),
        )?;
    }
    Ok(())
}

/// After the world process died, cuts `trajectory.csv` back to its last complete tick (all
/// `robots` rows), and `events.jsonl` and `radio.csv` (when the run records it) to whole
/// lines of ticks up to it. The world writes each
/// tick with one `write_all`, but the kernel may cut a large write short when a fatal signal
/// arrives, so the records are made whole here rather than trusted. Returns the last tick.
pub fn trim_torn_records(dir: &Path, robots: usize) -> anyhow::Result<Option<u64>> {
    let path = dir.join("trajectory.csv");
    let text = std::fs::read(&path).with_context(|| format!("{}", path.display()))?;
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
    truncate(&path, keep as u64)?;

    let path = dir.join("events.jsonl");
    let text = std::fs::read_to_string(&path).unwrap_or_default();
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
        truncate(&path, kept as u64)?;
    }

    // `radio.csv` (opt-in): the header, then rows whose first column is their tick,
    // non-decreasing; keep whole lines up to the last whole trajectory tick.
    let path = dir.join("radio.csv");
    if let Ok(text) = std::fs::read(&path) {
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
            truncate(&path, kept as u64)?;
        }
    }
    Ok(last)
}

/// Cuts `path` to `len` bytes, refusing a symbolic link at its name.
fn truncate(path: &Path, len: u64) -> anyhow::Result<()> {
    safe_fs::open_existing_nofollow(path)
        .and_then(|f| f.set_len(len))
        .with_context(|| format!("cannot trim {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unused_dir_gives_racing_callers_distinct_new_directories() {
        let root = tempfile::tempdir().unwrap();
        let base = root.path().join("runs/x-s1-20261123-101010");
        let base = base.to_str().unwrap();
        let dirs: Vec<PathBuf> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..8)
                .map(|_| s.spawn(|| unused_dir(base).unwrap()))
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
        let dir = root.path().join("run");
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
        std::fs::write(dir.join("config.toml"), "x").unwrap();
        drop(held);
        let e = claim(&dir, false).unwrap_err().to_string();
        assert!(e.contains("config.toml") && e.contains("--force"), "{e}");
        let _again = claim(&dir, true).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(&dir)
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
        let e = claim(&other, true).unwrap_err().to_string();
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
        let e = claim(&foreign, true).unwrap_err().to_string();
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
        assert!(!is_marked(&foreign));
        assert!(claim(&foreign, true).is_err());
        std::fs::remove_file(foreign.join(MARK_FILE)).unwrap();
        std::fs::write(foreign.join(MARK_FILE), "something else\n").unwrap();
        assert!(!is_marked(&foreign));
        assert!(claim(&foreign, true).is_err());
        assert!(foreign.join("config.toml").exists());

        // Marked, but holding a subdirectory that is not its own: refused too.
        let sub = root.path().join("sub");
        drop(claim(&sub, false).unwrap());
        std::fs::create_dir_all(sub.join("photos")).unwrap();
        std::fs::create_dir_all(sub.join(STORAGE_DIR)).unwrap();
        let e = claim(&sub, true).unwrap_err().to_string();
        assert!(
            e.contains("holds photos/") && e.contains("nothing was removed"),
            "{e}"
        );
        assert!(sub.join("photos").is_dir() && sub.join(STORAGE_DIR).is_dir());

        // Marked with its own storage/ and config/: cleared, a link inside removed as a link.
        let run = root.path().join("run");
        drop(claim(&run, false).unwrap());
        std::fs::create_dir_all(run.join("storage")).unwrap();
        std::fs::write(run.join("storage/raft-0.state"), "x").unwrap();
        std::fs::write(run.join("config.toml"), "x").unwrap();
        std::os::unix::fs::symlink(&victim, run.join("trajectory.csv")).unwrap();
        drop(claim(&run, true).unwrap());
        assert!(!run.join("storage").exists() && !run.join("config.toml").exists());
        assert!(std::fs::symlink_metadata(run.join("trajectory.csv")).is_err());
        assert!(
            std::fs::read_to_string(&victim)
                .unwrap()
                .starts_with(MARK_TEXT)
        );
        // An empty directory holding only a mark and a lock is free without --force.
        drop(claim(&run, false).unwrap());
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
            let e = claim(&dir, force).unwrap_err();
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
        let e = claim(&dir, false).unwrap_err();
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
        let e = format!("{:#}", prepare(&dir, &cfg).unwrap_err());
        assert!(e.ends_with(&refused(&link)), "{e}");
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");

        // metrics.json, its temporary file and the room set aside for it.
        for name in ["metrics.json", "metrics.json.tmp", METRICS_ROOM] {
            let (dir, victim, link) = planted(root.path(), name);
            reserve_metrics_room(&dir, 2);
            if name == METRICS_ROOM {
                assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
            } else {
                let e = format!(
                    "{:#}",
                    write_metrics(&dir, &serde_json::json!({"a": 1})).unwrap_err()
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
        let e = format!("{:#}", trim_torn_records(&dir, 1).unwrap_err());
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
            let e = format!("{:#}", write_plots(&dir, &cfg).unwrap_err());
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
        assert_eq!(trim_torn_records(dir.path(), 2).unwrap(), Some(1));
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
        assert_eq!(trim_torn_records(dir.path(), 2).unwrap(), Some(1));
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
        assert_eq!(trim_torn_records(dir.path(), 2).unwrap(), Some(1));
        assert_eq!(
            std::fs::read_to_string(dir.path().join("radio.csv")).unwrap(),
            ""
        );
        std::fs::remove_file(dir.path().join("radio.csv")).unwrap();
        assert_eq!(trim_torn_records(dir.path(), 2).unwrap(), Some(1));
        assert!(!dir.path().join("radio.csv").exists());
    }
}
