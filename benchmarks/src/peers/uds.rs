//! The Unix-socket peer floor: the world listens on a stream socket in the run's directory
//! (removed with the run), each robot connects once. Per tick the world writes each robot's
//! slot with one `write` and collects the answers with `epoll` (non-blocking `recv` of
//! whatever is ready, no busy waiting); a robot blocks in `read` on its socket.

use std::io::{Read, Write};
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd, RawFd};
use std::os::unix::net::{UnixListener, UnixStream};
use std::time::Instant;

use anyhow::{Context, bail};
use swarmrt_protocol::CommandKind;
use swarmrt_protocol::services::RunServices;

use super::{CMD_BYTES, OBS_BYTES, WorldLink, answer, command, drive, read_command, startup_limit};
use crate::PEER_TIMEOUT;
use crate::child::{ChildMsg, say};

/// `epoll` data of the listening socket (connections carry their index).
const LISTENER: u64 = u64::MAX;

struct Conn {
    stream: UnixStream,
    robot: Option<u32>,
    buf: Vec<u8>,
    filled: usize,
}

struct UdsWorld {
    epoll: OwnedFd,
    listener: UnixListener,
    conns: Vec<Conn>,
    /// Connection index of each robot, once it said hello.
    by_robot: Vec<Option<usize>>,
    events: Vec<libc::epoll_event>,
}

fn epoll_add(epoll: RawFd, fd: RawFd, data: u64) -> anyhow::Result<()> {
    let mut ev = libc::epoll_event {
        events: libc::EPOLLIN as u32,
        u64: data,
    };
    // SAFETY: both descriptors are open; epoll_ctl only reads `ev`.
    if unsafe { libc::epoll_ctl(epoll, libc::EPOLL_CTL_ADD, fd, &mut ev) } != 0 {
        return Err(std::io::Error::last_os_error()).context("epoll_ctl");
    }
    Ok(())
}

impl UdsWorld {
    fn new(listener: UnixListener, n: usize) -> anyhow::Result<UdsWorld> {
        // SAFETY: epoll_create1 returns a new descriptor or -1.
        let fd = unsafe { libc::epoll_create1(libc::EPOLL_CLOEXEC) };
        if fd < 0 {
            return Err(std::io::Error::last_os_error()).context("epoll_create1");
        }
        // SAFETY: `fd` is a fresh descriptor that nothing else owns.
        let epoll = unsafe { OwnedFd::from_raw_fd(fd) };
        listener.set_nonblocking(true)?;
        epoll_add(epoll.as_raw_fd(), listener.as_raw_fd(), LISTENER)?;
        Ok(UdsWorld {
            epoll,
            listener,
            conns: Vec::with_capacity(n),
            by_robot: vec![None; n],
            events: vec![libc::epoll_event { events: 0, u64: 0 }; 256],
        })
    }

    fn accept(&mut self) -> anyhow::Result<()> {
        loop {
            match self.listener.accept() {
                Ok((stream, _)) => {
                    // Accepted sockets are blocking (writes); reads use MSG_DONTWAIT.
                    stream.set_nonblocking(false)?;
                    let idx = self.conns.len() as u64;
                    epoll_add(self.epoll.as_raw_fd(), stream.as_raw_fd(), idx)?;
                    self.conns.push(Conn {
                        stream,
                        robot: None,
                        buf: vec![0; CMD_BYTES],
                        filled: 0,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(()),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e).context("accept"),
            }
        }
    }

    /// Reads whatever connection `idx` has; hands on every complete command. True when at
    /// least one was complete.
    fn drain(&mut self, idx: usize, on: &mut dyn FnMut(&[u8])) -> anyhow::Result<bool> {
        let mut got = false;
        loop {
            let c = &mut self.conns[idx];
            let want = CMD_BYTES - c.filled;
            // SAFETY: the buffer has `want` bytes from `filled`; recv writes at most that.
            let r = unsafe {
                libc::recv(
                    c.stream.as_raw_fd(),
                    c.buf[c.filled..].as_mut_ptr().cast(),
                    want,
                    libc::MSG_DONTWAIT,
                )
            };
            if r > 0 {
                c.filled += r as usize;
                if c.filled == CMD_BYTES {
                    c.filled = 0;
                    if c.robot.is_none()
                        && let Some(a) = read_command(&c.buf)
                        && a.kind == Some(CommandKind::Hello)
                        && let Some(slot) = self.by_robot.get_mut(a.robot as usize)
                    {
                        if slot.is_some() {
                            bail!("two connections said hello as robot {}", a.robot);
                        }
                        *slot = Some(idx);
                        c.robot = Some(a.robot);
                    }
                    on(&c.buf);
                    got = true;
                }
                continue;
            }
            if r == 0 {
                match c.robot {
                    Some(id) => bail!("robot {id} closed its socket (its process ended)"),
                    None => bail!("a robot closed its socket before its hello"),
                }
            }
            let e = std::io::Error::last_os_error();
            match e.kind() {
                std::io::ErrorKind::WouldBlock => return Ok(got),
                std::io::ErrorKind::Interrupted => {}
                _ => {
                    return Err(e).with_context(|| match c.robot {
                        Some(id) => format!("reading robot {id}'s socket"),
                        None => "reading a robot's socket".to_string(),
                    });
                }
            }
        }
    }
}

impl WorldLink for UdsWorld {
    fn send(&mut self, robot: u32, msg: &[u8]) -> anyhow::Result<()> {
        let idx = self
            .by_robot
            .get(robot as usize)
            .copied()
            .flatten()
            .with_context(|| format!("robot {robot} has no connection"))?;
        self.conns[idx]
            .stream
            .write_all(msg)
            .with_context(|| format!("writing to robot {robot}'s socket"))
    }

    fn receive(&mut self, deadline: Instant, on: &mut dyn FnMut(&[u8])) -> anyhow::Result<()> {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            // Rounded up, so the wait never ends just before the deadline.
            let timeout = left.as_micros().div_ceil(1000).min(i32::MAX as u128) as i32;
            // SAFETY: `events` has room for its length; epoll_wait writes at most that many.
            let r = unsafe {
                libc::epoll_wait(
                    self.epoll.as_raw_fd(),
                    self.events.as_mut_ptr(),
                    self.events.len() as i32,
                    timeout,
                )
            };
            if r < 0 {
                let e = std::io::Error::last_os_error();
                if e.kind() == std::io::ErrorKind::Interrupted {
                    continue;
                }
                return Err(e).context("epoll_wait");
            }
            if r == 0 {
                return Ok(());
            }
            let mut got = false;
            for k in 0..r as usize {
                let data = self.events[k].u64;
                if data == LISTENER {
                    self.accept()?;
                } else {
                    got |= self.drain(data as usize, on)?;
                }
            }
            if got || Instant::now() >= deadline {
                return Ok(());
            }
        }
    }
}

fn socket_path(run: &RunServices) -> std::path::PathBuf {
    run.ipc_root().join("peer-world.sock")
}

/// The UDS world: bind, say ready with the path, drive the lock-step.
pub fn world(run_id: &str, n: usize, ticks: u64) -> anyhow::Result<()> {
    let run = RunServices::new(run_id);
    let path = socket_path(&run);
    let _ = std::fs::remove_file(&path);
    let listener = UnixListener::bind(&path).with_context(|| format!("bind {}", path.display()))?;
    let mut link = UdsWorld::new(listener, n)?;
    say(&ChildMsg::Ready {
        addr: Some(path.display().to_string()),
    })?;
    let r = drive(&mut link, "UDS", n, ticks);
    drop(link);
    let _ = std::fs::remove_file(&path);
    r
}

/// A UDS robot: connect, hello, then block in `read` and answer each slot until shutdown.
pub fn agent(robot: u32, robots: usize, addr: &str, die_at: Option<u64>) -> anyhow::Result<()> {
    let mut stream = UnixStream::connect(addr).with_context(|| format!("connect {addr}"))?;
    // The first slot comes once every robot said hello.
    stream.set_read_timeout(Some(startup_limit(robots)))?;
    let mut out = vec![0u8; CMD_BYTES];
    command(&mut out, robot, 0, CommandKind::Hello);
    stream.write_all(&out).context("hello")?;
    let mut msg = vec![0u8; OBS_BYTES];
    let mut first = true;
    loop {
        if let Err(e) = stream.read_exact(&mut msg) {
            match e.kind() {
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut => {
                    bail!("robot {robot}: nothing from the world in time")
                }
                _ => return Err(e).context(format!("robot {robot}: read")),
            }
        }
        if first {
            stream.set_read_timeout(Some(PEER_TIMEOUT))?;
            first = false;
        }
        match answer(&msg, robot, die_at, &mut out)? {
            None => return Ok(()),
            Some(()) => stream
                .write_all(&out)
                .with_context(|| format!("robot {robot}: write"))?,
        }
    }
}
