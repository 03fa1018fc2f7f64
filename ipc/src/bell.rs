//! The tick bell: one futex word in the run's shared-memory root. The world bumps it once
//! per published observation sample and wakes every robot waiting on it with a single
//! `FUTEX_WAKE`, where an iceoryx2 notification costs one datagram and one wake-up call per
//! listener: at 1,000 robots that loop was most of a tick (docs/benchmarks.md, issue 34).
//!
//! The bell carries no data. Observations still travel in iceoryx2 samples; the bell only
//! says "look now". A robot reads the bell's count *before* draining its subscriber and
//! sleeps only while the count is still that value, so a sample sent after the read is never
//! slept through (the kernel compares the word and sleeps atomically).
//!
//! The way back uses the same file. Each robot of this build counts its answer on a second
//! word and notifies the world's listener only when the count reaches the target the world
//! set for the tick (the robots it waits for), so one notification wakes the world per tick
//! instead of one per robot. A target of 0 (a host, real-time mode, rounds) means every
//! robot notifies, as robots in other languages always do.
//!
//! Trust: the file lives in the run's private root (mode 0700, [`crate::cleanup::claim`]) and
//! goes with it on cleanup. A process of the same user that writes the words can only cause
//! spurious, early or late wake-ups, which the world's deadline and the robots' watchdog wait
//! already absorb: the words say when to look, never what was sent.

use std::io;
use std::os::fd::AsRawFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::PathBuf;
use std::ptr::NonNull;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::time::Duration;

use swarmrt_protocol::services::RunServices;

/// File name of the bell inside the run's iceoryx2 root.
pub const BELL_FILE: &str = "tick.bell";

/// Bytes mapped: three cache lines, so the robots' counting does not share a line with the
/// word they sleep on. The tick count is at offset 0.
const BELL_LEN: usize = 192;
/// Offset of the answer count (u64), bumped by each counting robot after its command.
const ANSWERS: usize = 64;
/// Offset of the target (u64): the answer count at which a robot notifies the world.
const TARGET: usize = 128;

/// Why [`Bell::wait`] returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Woke {
    /// The count moved past the value the caller had seen: something was published.
    Rung,
    /// The timeout passed with the count unchanged.
    TimedOut,
    /// A signal interrupted the wait (SIGTERM, SIGINT, or the SIGCONT that ends a freeze).
    Interrupted,
}

/// A mapping of a run's bell.
pub struct Bell {
    word: NonNull<AtomicU32>,
}

// SAFETY: the mapping is shared memory accessed only through the atomic; it lives until drop.
unsafe impl Send for Bell {}
// SAFETY: as above; every access is an atomic operation or a futex call on the word.
unsafe impl Sync for Bell {}

/// Where run `run`'s bell lives.
pub fn path(run: &RunServices) -> PathBuf {
    run.ipc_root().join(BELL_FILE)
}

impl Bell {
    /// Creates (or takes over) run `run`'s bell, as the process that publishes observations
    /// does. The file is never a link (`O_NOFOLLOW`) and is readable only by this user.
    pub fn create(run: &RunServices) -> io::Result<Bell> {
        Bell::create_at(&path(run))
    }

    fn create_at(at: &std::path::Path) -> io::Result<Bell> {
        if let Some(root) = at.parent()
            && !root.exists()
        {
            use std::os::unix::fs::DirBuilderExt;
            std::fs::DirBuilder::new()
                .recursive(true)
                .mode(0o700)
                .create(root)?;
        }
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .mode(0o600)
            .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
            .open(at)?;
        file.set_len(BELL_LEN as u64)?;
        Bell::map(&file, libc::PROT_READ | libc::PROT_WRITE)
    }

    /// Opens run `run`'s bell, as a robot does. Fails when the world has not created it (for
    /// example a world of an older build).
    pub fn open(run: &RunServices) -> io::Result<Bell> {
        Bell::open_at(&path(run))
    }

    fn open_at(at: &std::path::Path) -> io::Result<Bell> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
            .open(at)?;
        let meta = file.metadata()?;
        if !meta.is_file() || meta.len() < BELL_LEN as u64 {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "{} is not a bell (a regular file of {BELL_LEN} bytes)",
                    at.display()
                ),
            ));
        }
        Bell::map(&file, libc::PROT_READ | libc::PROT_WRITE)
    }

    fn map(file: &std::fs::File, prot: libc::c_int) -> io::Result<Bell> {
        // SAFETY: a fresh shared mapping of BELL_LEN bytes of a file at least that long; the
        // result is checked before use and unmapped in drop.
        let ptr = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                BELL_LEN,
                prot,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        if ptr == libc::MAP_FAILED {
            return Err(io::Error::last_os_error());
        }
        let word = NonNull::new(ptr.cast::<AtomicU32>()).ok_or_else(io::Error::last_os_error)?;
        Ok(Bell { word })
    }

    fn word(&self) -> &AtomicU32 {
        // SAFETY: mapped, page-aligned and alive as long as self.
        unsafe { self.word.as_ref() }
    }

    fn counter(&self, offset: usize) -> &AtomicU64 {
        // SAFETY: offset + 8 <= BELL_LEN, 8-aligned inside a page-aligned mapping that lives
        // as long as self.
        unsafe {
            &*self
                .word
                .as_ptr()
                .cast::<u8>()
                .add(offset)
                .cast::<AtomicU64>()
        }
    }

    /// Robot side: counts one answer (call it after the command is sent). True when the
    /// count reached the world's target, so the world is waiting for this answer: notify it.
    pub fn answered(&self) -> bool {
        let n = self.counter(ANSWERS).fetch_add(1, Ordering::SeqCst) + 1;
        n >= self.counter(TARGET).load(Ordering::SeqCst)
    }

    /// World side: the answers counted so far.
    pub fn answers(&self) -> u64 {
        self.counter(ANSWERS).load(Ordering::SeqCst)
    }

    /// World side: robots notify once the count reaches `target` (0: every robot notifies).
    pub fn expect(&self, target: u64) {
        self.counter(TARGET).store(target, Ordering::SeqCst);
    }

    /// The bell's count now. Read it before looking for samples, then [`Bell::wait`] with it.
    pub fn seen(&self) -> u32 {
        self.word().load(Ordering::Acquire)
    }

    /// Bumps the count and wakes every process waiting on the bell, in one system call. Call
    /// it after the sample is sent.
    pub fn ring(&self) -> io::Result<()> {
        self.word().fetch_add(1, Ordering::Release);
        // SAFETY: FUTEX_WAKE on a mapped, aligned u32 of a shared mapping.
        let r = unsafe {
            libc::syscall(
                libc::SYS_futex,
                self.word.as_ptr(),
                libc::FUTEX_WAKE,
                i32::MAX,
                std::ptr::null::<libc::timespec>(),
                std::ptr::null::<u32>(),
                0u32,
            )
        };
        if r < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// Sleeps until the count differs from `seen`, `timeout` passes, or a signal arrives.
    /// Returns at once when the count already differs.
    pub fn wait(&self, seen: u32, timeout: Duration) -> io::Result<Woke> {
        if self.seen() != seen {
            return Ok(Woke::Rung);
        }
        let ts = libc::timespec {
            tv_sec: timeout.as_secs().min(i64::MAX as u64) as libc::time_t,
            tv_nsec: timeout.subsec_nanos() as libc::c_long,
        };
        // SAFETY: FUTEX_WAIT on a mapped, aligned u32 with a relative timeout we own.
        let r = unsafe {
            libc::syscall(
                libc::SYS_futex,
                self.word.as_ptr(),
                libc::FUTEX_WAIT,
                seen,
                &ts as *const libc::timespec,
                std::ptr::null::<u32>(),
                0u32,
            )
        };
        if r == 0 {
            // Woken; a wake without a new count (another futex user) reads as a ring whose
            // caller finds nothing new and waits again.
            return Ok(Woke::Rung);
        }
        let e = io::Error::last_os_error();
        match e.raw_os_error() {
            Some(libc::EAGAIN) => Ok(Woke::Rung),
            Some(libc::ETIMEDOUT) => Ok(Woke::TimedOut),
            Some(libc::EINTR) => Ok(Woke::Interrupted),
            _ => Err(e),
        }
    }
}

impl Drop for Bell {
    fn drop(&mut self) {
        // SAFETY: unmaps exactly the mapping made in `map`.
        unsafe {
            libc::munmap(self.word.as_ptr().cast(), BELL_LEN);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    fn bell_dir() -> tempfile::TempDir {
        tempfile::Builder::new()
            .prefix("bell")
            .tempdir_in("/dev/shm")
            .unwrap()
    }

    #[test]
    fn a_ring_wakes_every_waiter_and_a_late_waiter_does_not_sleep() {
        let dir = bell_dir();
        let at = dir.path().join(BELL_FILE);
        let world = Bell::create_at(&at).unwrap();
        let seen = Bell::open_at(&at).unwrap().seen();
        let waiters: Vec<_> = (0..4)
            .map(|_| {
                let bell = Bell::open_at(&at).unwrap();
                std::thread::spawn(move || bell.wait(seen, Duration::from_secs(20)).unwrap())
            })
            .collect();
        std::thread::sleep(Duration::from_millis(50));
        let t = Instant::now();
        world.ring().unwrap();
        for w in waiters {
            assert_eq!(w.join().unwrap(), Woke::Rung);
        }
        assert!(t.elapsed() < Duration::from_secs(10), "waiters slept on");
        // Rung before the wait: the wait returns at once.
        let late = Bell::open_at(&at).unwrap();
        assert_eq!(late.seen(), seen.wrapping_add(1));
        assert_eq!(
            late.wait(seen, Duration::from_secs(20)).unwrap(),
            Woke::Rung
        );
        // Unchanged: the wait times out.
        let now = late.seen();
        assert_eq!(
            late.wait(now, Duration::from_millis(20)).unwrap(),
            Woke::TimedOut
        );
        // A second world process (a restarted host) takes the bell over without resetting it.
        let again = Bell::create_at(&at).unwrap();
        assert_eq!(again.seen(), now);
    }

    #[test]
    fn only_the_answer_that_reaches_the_target_notifies() {
        let dir = bell_dir();
        let at = dir.path().join(BELL_FILE);
        let world = Bell::create_at(&at).unwrap();
        let robots: Vec<Bell> = (0..3).map(|_| Bell::open_at(&at).unwrap()).collect();
        // No target: everyone notifies.
        assert!(robots[0].answered());
        let base = world.answers();
        assert_eq!(base, 1);
        world.expect(base + 3);
        assert!(!robots[0].answered());
        assert!(!robots[1].answered());
        assert!(robots[2].answered(), "the third answer reaches the target");
        assert_eq!(world.answers(), base + 3);
        // A robot that answers twice only moves the notification earlier.
        world.expect(world.answers() + 2);
        assert!(!robots[0].answered());
        assert!(robots[0].answered());
        assert!(
            robots[1].answered(),
            "past the target every answer notifies"
        );
        world.expect(0);
        assert!(robots[1].answered());
    }

    #[test]
    fn a_missing_short_or_linked_bell_is_refused() {
        let dir = bell_dir();
        let at = dir.path().join(BELL_FILE);
        assert!(Bell::open_at(&at).is_err());
        std::fs::write(&at, [0u8; 4]).unwrap();
        let e = Bell::open_at(&at).err().unwrap();
        assert!(e.to_string().contains("is not a bell"), "{e}");
        std::fs::remove_file(&at).unwrap();
        let target = dir.path().join("elsewhere");
        std::fs::write(&target, [0u8; BELL_LEN]).unwrap();
        std::os::unix::fs::symlink(&target, &at).unwrap();
        assert!(Bell::open_at(&at).is_err());
        assert!(Bell::create_at(&at).is_err());
    }
}
