//! Emulated hosts on one machine for the multi-host tests: one network namespace per host,
//! joined by veth pairs to a bridge in a namespace of its own, and each host with its own
//! private `/dev/shm` (a tmpfs in a mount namespace held open by a sleeping process), because
//! network namespaces alone share `/dev/shm` and a run would silently bypass the network.
//!
//! Everything the lab makes is named after its tag and removed when it is dropped, on every
//! exit path of a test (panics included). Needs root (CI runs as root); where namespaces
//! cannot be made, [`Lab::new`] says why and the test fails rather than passing silently.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};

/// The emulated hosts.
pub struct Lab {
    tag: String,
    holders: Vec<Child>,
    namespaces: Vec<String>,
}

fn ip(args: &[&str]) -> Result<(), String> {
    let out = Command::new("ip")
        .args(args)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run `ip` (iproute2): {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "`ip {}` failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Installs iproute2 (`ip`) with apt when it is missing, once per test process, so the README's
/// test command needs no set-up step on a fresh Debian machine. `nsenter` and `unshare` come
/// with util-linux, which every Debian has.
fn ensure_iproute2() -> Result<(), String> {
    static DONE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        let have = |p: &str| {
            Command::new(p)
                .arg("-V")
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok()
        };
        if have("ip") {
            return Ok(());
        }
        let ok = crate::apt_install(&["iproute2"]).is_ok();
        if ok && have("ip") {
            Ok(())
        } else {
            Err("`ip` (iproute2) is missing and `apt-get install iproute2` failed".into())
        }
    })
    .clone()
}

impl Lab {
    /// `hosts` hosts at 10.77.0.1, 10.77.0.2, ... on one bridge.
    pub fn new(hosts: usize) -> Result<Lab, String> {
        ensure_iproute2()?;
        static NEXT: AtomicU32 = AtomicU32::new(0);
        let tag = format!(
            "{}{}",
            std::process::id() % 100_000,
            NEXT.fetch_add(1, Ordering::SeqCst)
        );
        let mut lab = Lab {
            tag: tag.clone(),
            holders: Vec::new(),
            namespaces: Vec::new(),
        };
        let br = format!("swlab{tag}br");
        ip(&["netns", "add", &br])?;
        lab.namespaces.push(br.clone());
        ip(&["-n", &br, "link", "add", "br0", "type", "bridge"])?;
        ip(&["-n", &br, "link", "set", "br0", "up"])?;
        for i in 0..hosts {
            let ns = lab.netns(i);
            ip(&["netns", "add", &ns])?;
            lab.namespaces.push(ns.clone());
            let (a, b) = (format!("h{i}"), format!("b{i}"));
            ip(&[
                "link", "add", &a, "netns", &ns, "type", "veth", "peer", "name", &b, "netns", &br,
            ])?;
            ip(&[
                "-n",
                &ns,
                "addr",
                "add",
                &format!("{}/24", lab.addr(i)),
                "dev",
                &a,
            ])?;
            ip(&["-n", &ns, "link", "set", &a, "up"])?;
            ip(&["-n", &ns, "link", "set", "lo", "up"])?;
            ip(&["-n", &br, "link", "set", &b, "master", "br0", "up"])?;
            // The holder: a mount namespace with its own /dev/shm, inside the host's netns.
            let mut holder = Command::new("ip")
                .args([
                    "netns",
                    "exec",
                    &ns,
                    "unshare",
                    "--mount",
                    "--propagation",
                    "private",
                ])
                .args([
                    "sh",
                    "-c",
                    "mount -t tmpfs swlab /dev/shm && echo ready && exec sleep 100000",
                ])
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .spawn()
                .map_err(|e| format!("cannot start the holder of host {i}: {e}"))?;
            let mut line = String::new();
            let _ = BufReader::new(holder.stdout.take().expect("piped")).read_line(&mut line);
            lab.holders.push(holder);
            if line.trim() != "ready" {
                return Err(format!(
                    "host {i}: cannot give it a private /dev/shm (unshare --mount, mount tmpfs)"
                ));
            }
        }
        Ok(lab)
    }

    /// The network namespace of host `i`.
    pub fn netns(&self, i: usize) -> String {
        format!("swlab{}h{i}", self.tag)
    }

    /// The address of host `i`.
    pub fn addr(&self, i: usize) -> String {
        format!("10.77.0.{}", i + 1)
    }

    /// A command prefix that runs a program on host `i` (its network and its /dev/shm).
    pub fn launcher(&self, i: usize) -> Vec<String> {
        vec![
            "nsenter".into(),
            "-t".into(),
            self.holders[i].id().to_string(),
            "-n".into(),
            "-m".into(),
            "--".into(),
        ]
    }

    /// Kills everything on host `i`, its holder too: the host is gone, and its launcher fails
    /// from now on (`nsenter` finds no process to enter).
    pub fn kill_host(&mut self, i: usize) {
        for pid in self.processes(i) {
            // SAFETY: kill has no memory effects.
            unsafe {
                libc::kill(pid, libc::SIGKILL);
            }
        }
        let _ = self.holders[i].kill();
        let _ = self.holders[i].wait();
    }

    /// Pids of every process in host `i`'s network namespace but its holder.
    pub fn processes(&self, i: usize) -> Vec<i32> {
        let out = Command::new("ip")
            .args(["netns", "pids", &self.netns(i)])
            .output()
            .expect("ip netns pids");
        let holder = self.holders[i].id() as i32;
        String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .filter_map(|p| p.parse().ok())
            .filter(|&p| p != holder)
            .collect()
    }

    /// Entries of host `i`'s private /dev/shm (iceoryx2's files and segments of any run).
    pub fn shm(&self, i: usize) -> Vec<String> {
        let mut cmd = Command::new(&self.launcher(i)[0]);
        cmd.args(&self.launcher(i)[1..])
            .args(["ls", "-A", "/dev/shm"]);
        let out = cmd.output().expect("ls /dev/shm on a host");
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .map(str::to_string)
            .collect()
    }
}

impl Drop for Lab {
    fn drop(&mut self) {
        for i in 0..self.holders.len() {
            // Whatever a failed test left running on the host goes first.
            for pid in self.processes(i) {
                unsafe {
                    libc::kill(pid, libc::SIGKILL);
                }
            }
        }
        for h in &mut self.holders {
            let _ = h.kill();
            let _ = h.wait();
        }
        // Deleting a namespace deletes the veth ends and the bridge in it.
        for ns in self.namespaces.iter().rev() {
            let _ = ip(&["netns", "del", ns]);
        }
    }
}
