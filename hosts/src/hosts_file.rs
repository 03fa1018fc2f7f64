//! `hosts.toml`: where the robots of a run live when they do not all live beside the world.
//!
//! ```toml
//! [world]
//! listen = "quic/10.0.0.1:7447"     # the world's Zenoh endpoint; every host connects here
//! certs = "certs"                    # what `swarm certs hosts.toml` wrote (default: certs/
//!                                    # beside this file)
//!
//! [[host]]
//! name = "rack-a"
//! launcher = ["ssh", "rack-a"]       # prefixed to the swarm-host command line
//! robots = 40                        # a count, or an id range "20..60"
//! ```
//!
//! `quic/` endpoints (the default: TLS 1.3 over UDP) authenticate both ends with certificates
//! of one CA ([`crate::certs`]); `tcp/` trusts anyone on the network and needs
//! `--insecure-link`. Zenoh's `tls/` (over TCP) is refused: in zenoh 1.10 it drops the link
//! about once a second under a lock-step's steady traffic (zenoh issue #2557), each drop
//! looking like a lost host.
//!
//! Counts are laid out from the top ids down in file order, so the world's host keeps the
//! lowest ids; ranges are half-open and must not overlap. Robots no host names run beside the
//! world over iceoryx2 as on one host.

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use swarmrt_scenario::ConfigError;

/// A resolved `hosts.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct HostsFile {
    /// The world's listening endpoint.
    pub listen: String,
    /// The directory of the run's certificates on the world's host (`world.certs`, relative
    /// to the hosts file): the CA, the world's and every host's ([`crate::certs`]).
    pub certs: PathBuf,
    /// The remote hosts, in file order.
    pub hosts: Vec<Host>,
}

/// One remote host.
#[derive(Debug, Clone, PartialEq)]
pub struct Host {
    /// Its name (lower-case letters, digits and '-').
    pub name: String,
    /// The command prefixed to the `swarm-host` command line (ssh in real life).
    pub launcher: Vec<String>,
    /// The robot ids it runs.
    pub robots: Range<u32>,
    /// The endpoint it connects to (the world's `listen` unless given).
    pub connect: String,
    /// The `swarm-host` executable on that host (default: the one beside `swarm` here).
    pub program: Option<PathBuf>,
    /// Where its certificate, key and the CA are on that host (default: the world's `certs`).
    pub certs: PathBuf,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    world: RawWorld,
    #[serde(default)]
    host: Vec<RawHost>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    listen: String,
    certs: Option<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHost {
    name: String,
    launcher: Vec<String>,
    robots: RawRobots,
    connect: Option<String>,
    program: Option<PathBuf>,
    certs: Option<PathBuf>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RawRobots {
    Count(i64),
    Range(String),
}

/// Checks a Zenoh endpoint `quic/<address>:<port>` (or `tcp/`, see [`HostsFile::is_secure`]).
fn check_endpoint(file: &str, key: &str, e: &str) -> Result<(), ConfigError> {
    let bad = || {
        ConfigError::new(
            file,
            key,
            format!("expected a Zenoh endpoint \"quic/<address>:<port>\", found {e:?}"),
        )
    };
    if e.starts_with("tls/") {
        return Err(ConfigError::new(
            file,
            key,
            format!(
                "{e:?}: use quic/ instead of tls/ (the same certificates and checks; zenoh 1.10's tls/ link drops under steady traffic, zenoh issue #2557)"
            ),
        ));
    }
    let rest = e
        .strip_prefix("quic/")
        .or_else(|| e.strip_prefix("tcp/"))
        .ok_or_else(bad)?;
    let (addr, port) = rest.rsplit_once(':').ok_or_else(bad)?;
    if addr.is_empty() || port.parse::<u16>().map_or(true, |p| p == 0) {
        return Err(bad());
    }
    Ok(())
}

fn parse_range(file: &str, key: &str, s: &str) -> Result<Range<u32>, ConfigError> {
    let bad = || {
        ConfigError::new(
            file,
            key,
            format!("expected a count or an id range like \"4..8\", found {s:?}"),
        )
    };
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let a: u32 = a.trim().parse().map_err(|_| bad())?;
    let b: u32 = b.trim().parse().map_err(|_| bad())?;
    if a >= b {
        return Err(ConfigError::new(
            file,
            key,
            format!("the range {s:?} is empty"),
        ));
    }
    Ok(a..b)
}

impl HostsFile {
    /// Reads and checks `path` for a run of `robots` robots, including that every launcher
    /// is a program this machine can run.
    pub fn load(path: &Path, robots: u32) -> Result<HostsFile, ConfigError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ConfigError::new(&file, "", format!("cannot read: {e}")))?;
        let hosts = HostsFile::parse(&file, &text, robots)?;
        for (i, h) in hosts.hosts.iter().enumerate() {
            if !runnable(&h.launcher[0]) {
                return Err(ConfigError::new(
                    &file,
                    format!("host[{i}].launcher"),
                    format!(
                        "cannot find the program {:?} (not an executable file, nor on PATH)",
                        h.launcher[0]
                    ),
                ));
            }
        }
        Ok(hosts)
    }

    /// Checks the text of a hosts file named `file` for a run of `robots` robots.
    pub fn parse(file: &str, text: &str, robots: u32) -> Result<HostsFile, ConfigError> {
        let table: toml::Table = toml::from_str(text)
            .map_err(|e| ConfigError::new(file, "", e.message().to_string()))?;
        let raw: RawFile =
            serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
                let key = e.path().to_string().trim_start_matches('.').to_string();
                ConfigError::new(file, key, e.inner().to_string().replace('\n', " "))
            })?;
        check_endpoint(file, "world.listen", &raw.world.listen)?;
        // Relative to the hosts file, like a path in a config.
        let beside = Path::new(file).parent().unwrap_or(Path::new(""));
        let certs = beside.join(raw.world.certs.as_deref().unwrap_or(Path::new("certs")));
        // Absolute, so the world (started elsewhere) and the hosts' launchers find them too.
        let certs = std::path::absolute(&certs).unwrap_or(certs);
        if raw.host.is_empty() {
            return Err(ConfigError::new(
                file,
                "host",
                "expected at least one [[host]] table",
            ));
        }
        let counts = raw
            .host
            .iter()
            .filter(|h| matches!(h.robots, RawRobots::Count(_)))
            .count();
        if counts != 0 && counts != raw.host.len() {
            return Err(ConfigError::new(
                file,
                "host.robots",
                "give every host a count, or every host an id range, not a mix",
            ));
        }
        let mut hosts: Vec<Host> = Vec::new();
        let mut top = robots;
        for (i, h) in raw.host.into_iter().enumerate() {
            let key = |k: &str| format!("host[{i}].{k}");
            let name_ok = !h.name.is_empty()
                && h.name.len() <= 32
                && h.name
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-');
            if !name_ok {
                return Err(ConfigError::new(
                    file,
                    key("name"),
                    format!(
                        "expected 1-32 lower-case letters, digits or '-', found {:?}",
                        h.name
                    ),
                ));
            }
            if hosts.iter().any(|o| o.name == h.name) {
                return Err(ConfigError::new(
                    file,
                    key("name"),
                    format!("host {:?} is named twice", h.name),
                ));
            }
            if h.launcher.is_empty() || h.launcher[0].is_empty() {
                return Err(ConfigError::new(
                    file,
                    key("launcher"),
                    "expected a command, e.g. [\"ssh\", \"rack-a\"]",
                ));
            }
            let range = match h.robots {
                RawRobots::Count(c) => {
                    if c < 1 || c > top as i64 {
                        return Err(ConfigError::new(
                            file,
                            key("robots"),
                            format!(
                                "{c} is out of range: expected 1..={top} (robots.count = {robots}, less those of the hosts above)"
                            ),
                        ));
                    }
                    top -= c as u32;
                    top..top + c as u32
                }
                RawRobots::Range(s) => {
                    let r = parse_range(file, &key("robots"), &s)?;
                    if r.end > robots {
                        return Err(ConfigError::new(
                            file,
                            key("robots"),
                            format!("{s:?} goes past robots.count = {robots}"),
                        ));
                    }
                    if let Some(o) = hosts
                        .iter()
                        .find(|o| o.robots.start < r.end && r.start < o.robots.end)
                    {
                        return Err(ConfigError::new(
                            file,
                            key("robots"),
                            format!("{s:?} overlaps host {:?}", o.name),
                        ));
                    }
                    r
                }
            };
            let connect = h.connect.unwrap_or_else(|| raw.world.listen.clone());
            check_endpoint(file, &key("connect"), &connect)?;
            let scheme = |e: &str| e.split_once('/').map(|(s, _)| s.to_string());
            if scheme(&connect) != scheme(&raw.world.listen) {
                return Err(ConfigError::new(
                    file,
                    key("connect"),
                    format!(
                        "{connect:?} does not use world.listen's scheme: every end of the link must be quic/, or every end tcp/"
                    ),
                ));
            }
            hosts.push(Host {
                certs: h.certs.unwrap_or_else(|| certs.clone()),
                name: h.name,
                launcher: h.launcher,
                robots: range,
                connect,
                program: h.program,
            });
        }
        Ok(HostsFile {
            listen: raw.world.listen,
            certs,
            hosts,
        })
    }

    /// True when the link is mutually authenticated TLS (`quic/` endpoints); `tcp/` trusts
    /// anyone who can reach the world's port and needs `--insecure-link`.
    pub fn is_secure(&self) -> bool {
        self.listen.starts_with("quic/")
    }

    /// The one line `swarm run` refuses an insecure link with, unless the user said
    /// `--insecure-link`.
    pub fn insecure_refusal(&self, file: &Path) -> String {
        format!(
            "{}: world.listen {:?} is plain TCP: anyone who can reach it could read the run and pose as a host; use quic/ endpoints (`swarm certs {}` makes the certificates) or pass --insecure-link on a private lab network",
            file.display(),
            self.listen,
            file.display()
        )
    }

    /// The host running `robot`, if a remote one does.
    pub fn host_of(&self, robot: u32) -> Option<usize> {
        self.hosts.iter().position(|h| h.robots.contains(&robot))
    }

    /// True when `robot` runs beside the world.
    pub fn is_local(&self, robot: u32) -> bool {
        self.host_of(robot).is_none()
    }
}

/// True when `program` names an executable file, directly or through `PATH`.
fn runnable(program: &str) -> bool {
    use std::os::unix::fs::PermissionsExt;
    let exec = |p: &Path| {
        std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    };
    if program.contains('/') {
        return exec(Path::new(program));
    }
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|d| exec(&d.join(program))))
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[world]
listen = "tcp/10.0.0.1:7447"
[[host]]
name = "a"
launcher = ["ssh", "a"]
robots = 4
[[host]]
name = "b"
launcher = ["ssh", "b"]
robots = 3
connect = "tcp/10.0.1.1:7447"
"#;

    #[test]
    fn counts_take_the_top_ids_in_file_order() {
        let h = HostsFile::parse("h.toml", GOOD, 10).unwrap();
        assert_eq!(h.hosts[0].robots, 6..10);
        assert_eq!(h.hosts[1].robots, 3..6);
        assert_eq!(h.hosts[0].connect, "tcp/10.0.0.1:7447");
        assert_eq!(h.hosts[1].connect, "tcp/10.0.1.1:7447");
        assert_eq!(h.host_of(2), None);
        assert_eq!(h.host_of(9), Some(0));
    }

    fn err(text: &str, robots: u32) -> String {
        HostsFile::parse("h.toml", text, robots)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn mistakes_name_the_file_and_key() {
        let e = err(GOOD, 5);
        assert!(e.contains("h.toml") && e.contains("host[1].robots"), "{e}");
        let e = err(&GOOD.replace("tcp/10.0.0.1:7447", "udp/x"), 10);
        assert!(
            e.contains("world.listen") && e.contains("quic/<address>:<port>"),
            "{e}"
        );
        let e = err(&GOOD.replace("name = \"b\"", "name = \"a\""), 10);
        assert!(e.contains("host[1].name") && e.contains("twice"), "{e}");
        let e = err(&GOOD.replace("robots = 3", "robots = \"2..9\""), 10);
        assert!(e.contains("not a mix"), "{e}");
        let ranges = GOOD
            .replace("robots = 4", "robots = \"0..4\"")
            .replace("robots = 3", "robots = \"3..6\"");
        let e = err(&ranges, 10);
        assert!(e.contains("overlaps host \"a\""), "{e}");
        let e = err(
            &GOOD.replace("launcher = [\"ssh\", \"a\"]", "launcher = []"),
            10,
        );
        assert!(e.contains("host[0].launcher"), "{e}");
        let e = err(&GOOD.replace("robots = 4", "robots = 4\nport = 3"), 10);
        assert!(e.contains("port"), "{e}");
    }

    #[test]
    fn every_end_of_the_link_uses_one_scheme_and_tls_is_secure() {
        let tls = GOOD.replace("tcp/", "quic/");
        let h = HostsFile::parse("h.toml", &tls, 10).unwrap();
        assert!(h.is_secure());
        assert!(h.certs.is_absolute() && h.certs.ends_with("certs"));
        assert!(h.hosts.iter().all(|x| x.certs == h.certs));
        assert!(!HostsFile::parse("h.toml", GOOD, 10).unwrap().is_secure());
        let mixed = tls.replacen("quic/10.0.1.1", "tcp/10.0.1.1", 1);
        let e = HostsFile::parse("h.toml", &mixed, 10)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("host[1].connect") && e.contains("every end"),
            "{e}"
        );
        let old = GOOD.replace("tcp/", "tls/");
        let e = HostsFile::parse("h.toml", &old, 10)
            .unwrap_err()
            .to_string();
        assert!(e.contains("world.listen") && e.contains("use quic/"), "{e}");
    }
}
