//! A real one-node Slurm cluster for the executor tests: Debian's `slurmctld` and `slurmd`
//! on this machine with munge, installed when missing (as the multi-host lab installs
//! iproute2), started with a configuration of their own (own ports, own state directories,
//! `SLURM_CONF` pointing at it) and stopped when the [`SlurmLab`] is dropped.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// A running controller and node daemon; dropped, both stop (and munged, if the lab started it).
pub struct SlurmLab {
    dir: PathBuf,
    conf: PathBuf,
    daemons: Vec<Child>,
    munged: Option<u32>,
}

/// Debian's packages of a controller, a node daemon, the client commands and munge.
const PACKAGES: [&str; 4] = ["slurmctld", "slurmd", "slurm-client", "munge"];

impl SlurmLab {
    /// Installs what is missing, starts the daemons and waits until the node is idle.
    pub fn start() -> Result<SlurmLab, String> {
        let have = ["slurmctld", "slurmd", "sbatch", "munged"]
            .iter()
            .all(|p| which(p).is_some());
        if !have {
            crate::apt_install(&PACKAGES)?;
        }
        let munged = ensure_munge()?;
        static N: AtomicU32 = AtomicU32::new(0);
        let dir = std::env::temp_dir().join(format!(
            "swarmrt-slurm-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::SeqCst)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        for d in ["state", "spool"] {
            std::fs::create_dir_all(dir.join(d)).map_err(|e| e.to_string())?;
        }
        let host = short_hostname();
        let (ctl_port, node_port) = (free_port()?, free_port()?);
        let conf = dir.join("slurm.conf");
        let d = dir.display();
        // One node with this machine's two cores, consumable cores (two tasks at once), no
        // cgroups or accounting: what a container without systemd can run.
        let text = format!(
            "ClusterName=swarmrt\n\
             SlurmctldHost={host}(127.0.0.1)\n\
             SlurmUser=root\n\
             SlurmdUser=root\n\
             AuthType=auth/munge\n\
             CredType=cred/munge\n\
             SlurmctldPort={ctl_port}\n\
             SlurmdPort={node_port}\n\
             StateSaveLocation={d}/state\n\
             SlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\n\
             SlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/slurmctld.log\n\
             SlurmdLogFile={d}/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_Core\n\
             JobAcctGatherType=jobacct_gather/none\n\
             AccountingStorageType=accounting_storage/none\n\
             MpiDefault=none\n\
             ReturnToService=2\n\
             SchedulerParameters=sched_interval=1\n\
             MinJobAge=300\n\
             KillWait=5\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs=2 RealMemory=2000 State=UNKNOWN\n\
             PartitionName=debug Nodes={host} Default=YES MaxTime=INFINITE State=UP\n"
        );
        std::fs::write(&conf, text).map_err(|e| e.to_string())?;
        let mut lab = SlurmLab {
            dir,
            conf,
            daemons: Vec::new(),
            munged,
        };
        for (daemon, log) in [("slurmctld", "slurmctld.out"), ("slurmd", "slurmd.out")] {
            let out = std::fs::File::create(lab.dir.join(log)).map_err(|e| e.to_string())?;
            let mut cmd = Command::new(daemon);
            // Foreground (-D) so the lab owns them; -i: ignore any saved state.
            cmd.args(["-D", "-f"]).arg(&lab.conf);
            if daemon == "slurmctld" {
                cmd.arg("-i");
            }
            let child = cmd
                .env("SLURM_CONF", &lab.conf)
                .stdin(Stdio::null())
                .stdout(out.try_clone().map_err(|e| e.to_string())?)
                .stderr(out)
                .spawn()
                .map_err(|e| format!("cannot start {daemon}: {e}"))?;
            lab.daemons.push(child);
        }
        let started = Instant::now();
        let deadline = started + Duration::from_secs(60);
        loop {
            let state = lab.command("sinfo").args(["-h", "-o", "%T"]).output();
            if state.is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle") {
                eprintln!(
                    "slurm lab: node idle {:.1} s after start ({})",
                    started.elapsed().as_secs_f64(),
                    lab.dir.display()
                );
                return Ok(lab);
            }
            if Instant::now() > deadline {
                return Err(format!(
                    "the Slurm node did not become idle in 60 s; see {}",
                    lab.dir.display()
                ));
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// The environment a client of this cluster needs.
    pub fn env(&self) -> Vec<(&str, &str)> {
        vec![("SLURM_CONF", self.conf.to_str().expect("a UTF-8 temp path"))]
    }

    /// A Slurm client command (`squeue`, `scancel`, ...) aimed at this cluster.
    pub fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf).stdin(Stdio::null());
        c
    }

    /// `squeue` lines `<job>_<task> <state>` of every task the controller knows.
    pub fn tasks(&self) -> Vec<(String, String)> {
        let out = self
            .command("squeue")
            .args(["-h", "-r", "--states=all", "-o", "%i %T"])
            .output()
            .expect("squeue runs");
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| {
                let (id, state) = l.trim().split_once(' ')?;
                Some((id.to_string(), state.to_string()))
            })
            .collect()
    }

    /// The directory holding the daemons' configuration and logs.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

impl Drop for SlurmLab {
    fn drop(&mut self) {
        for d in &mut self.daemons {
            // SAFETY: kill has no memory effects; the pid is our unreaped child.
            unsafe {
                libc::kill(d.id() as i32, libc::SIGTERM);
            }
        }
        for d in &mut self.daemons {
            let deadline = Instant::now() + Duration::from_secs(10);
            while d.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = d.kill();
            let _ = d.wait();
        }
        if let Some(pid) = self.munged {
            // SAFETY: as above; munged is ours (we started it and read its pid file).
            unsafe {
                libc::kill(pid as i32, libc::SIGTERM);
            }
        }
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// Starts munged when no munge daemon answers; returns its pid when the lab started it.
fn ensure_munge() -> Result<Option<u32>, String> {
    let works = || {
        Command::new("munge")
            .arg("-n")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if works() {
        return Ok(None);
    }
    let key = Path::new("/etc/munge/munge.key");
    if !key.exists() {
        let made = Command::new("mungekey")
            .args(["--create", "--keyfile"])
            .arg(key)
            .status()
            .is_ok_and(|s| s.success());
        if !made {
            return Err("no /etc/munge/munge.key and `mungekey --create` failed".into());
        }
    }
    for d in ["/run/munge", "/var/log/munge", "/var/lib/munge"] {
        let _ = std::fs::create_dir_all(d);
    }
    // --force: root may run it, and a stale socket of a dead daemon is replaced.
    let ok = Command::new("munged")
        .arg("--force")
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return Err("cannot start munged".into());
    }
    let deadline = Instant::now() + Duration::from_secs(10);
    while !works() {
        if Instant::now() > deadline {
            return Err("munged started but `munge -n` still fails".into());
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let pid = std::fs::read_to_string("/run/munge/munged.pid")
        .ok()
        .and_then(|p| p.trim().parse().ok());
    Ok(pid)
}

fn which(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .chain(["/usr/sbin".into(), "/sbin".into()])
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

/// The host name Slurm's node daemon looks itself up by (up to the first dot).
fn short_hostname() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: gethostname writes at most buf.len() bytes into buf.
    let r = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
    assert_eq!(r, 0, "gethostname");
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    let name = String::from_utf8_lossy(&buf[..end]).into_owned();
    name.split('.').next().unwrap_or("localhost").to_string()
}

/// A TCP port free right now on loopback.
fn free_port() -> Result<u16, String> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| format!("no free port: {e}"))
}
