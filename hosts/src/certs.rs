//! The certificates of a multi-host run (`swarm certs`, `swarm check --hosts`): one CA signs
//! the world's certificate (the TLS server, named by every address hosts connect to) and one
//! per host (a TLS client whose common name is the host's name in `hosts.toml`). The world's
//! access control matches a host by that name ([`crate::link::world_acl`]), so a host can
//! only ever speak as itself.
//!
//! Files in the certificates directory: `ca.pem` and `ca.key` (keep the key away from the
//! hosts), `world.pem`/`world.key`, `host-<name>.pem`/`host-<name>.key`. Keys are written
//! 0600, never over an existing file, never through a symbolic link, and all files or none:
//! a name already taken refuses the whole set before anything is written.

use std::io::Write;
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose, PublicKeyData,
};
use x509_parser::prelude::{FromDer, GeneralName, X509Certificate};

use crate::HostsFile;

/// Errors of `swarm certs` (each a line naming the file).
pub type CertError = Box<dyn std::error::Error + Send + Sync>;

/// The CA's certificate in `dir`.
pub fn ca_cert(dir: &Path) -> PathBuf {
    dir.join("ca.pem")
}

/// The world's certificate and key in `dir`.
pub fn world_pair(dir: &Path) -> (PathBuf, PathBuf) {
    (dir.join("world.pem"), dir.join("world.key"))
}

/// Host `name`'s certificate and key in `dir`.
pub fn host_pair(dir: &Path, name: &str) -> (PathBuf, PathBuf) {
    (
        dir.join(format!("host-{name}.pem")),
        dir.join(format!("host-{name}.key")),
    )
}

/// The address part of an endpoint `quic/<address>:<port>`, without IPv6 brackets.
fn address(endpoint: &str) -> &str {
    let rest = endpoint.split_once('/').map_or("", |(_, r)| r);
    let addr = rest.rsplit_once(':').map_or(rest, |(a, _)| a);
    addr.trim_start_matches('[').trim_end_matches(']')
}

/// The names the world's certificate must carry: every address a host connects to (and the
/// listening one, unless it is a wildcard).
pub fn world_names(file: &HostsFile) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    let all =
        std::iter::once(file.listen.as_str()).chain(file.hosts.iter().map(|h| h.connect.as_str()));
    for e in all {
        let a = address(e);
        if !a.is_empty() && a != "0.0.0.0" && a != "::" && !names.iter().any(|n| n == a) {
            names.push(a.to_string());
        }
    }
    names
}

/// Refuses a target that exists in any form: a symbolic link (never followed, never
/// replaced) or a file (never overwritten).
fn refuse_existing(path: &Path) -> Result<(), CertError> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!("cannot check {}: {e} (nothing was written)", path.display()).into()),
        Ok(m) if m.file_type().is_symlink() => Err(format!(
            "{} is a symbolic link; refusing to follow it (nothing was written)",
            path.display()
        )
        .into()),
        Ok(_) => Err(format!(
            "{} exists; swarm certs never overwrites a certificate or key (nothing was written: remove the old files, or write elsewhere with --out)",
            path.display()
        )
        .into()),
    }
}

/// Writes `bytes` to a new file `path` with `mode`; an existing file or a symbolic link is
/// refused, never replaced or followed.
fn write_new(path: &Path, bytes: &[u8], mode: u32) -> Result<(), CertError> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(mode)
        .custom_flags(libc::O_NOFOLLOW)
        .open(path)
        .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
    f.write_all(bytes)
        .and_then(|_| f.sync_all())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(())
}

/// Files written aside in a fresh private directory inside the target directory, then put in
/// place together: each by a hard link, which fails on any existing name (a link planted
/// meanwhile included) and never follows one. If one cannot be placed, the ones placed are
/// taken back, so a failure leaves nothing half-made.
struct Aside {
    dir: PathBuf,
    files: Vec<(PathBuf, PathBuf)>,
}

impl Aside {
    fn new(out: &Path) -> Result<Aside, CertError> {
        static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = out.join(format!(".swarm-certs-{}-{n}", std::process::id()));
        std::fs::DirBuilder::new()
            .mode(0o700)
            .create(&dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        Ok(Aside {
            dir,
            files: Vec::new(),
        })
    }

    fn write(&mut self, target: PathBuf, text: &str, mode: u32) -> Result<(), CertError> {
        let name = target
            .file_name()
            .ok_or("a certificate file needs a name")?;
        let aside = self.dir.join(name);
        write_new(&aside, text.as_bytes(), mode)?;
        self.files.push((aside, target));
        Ok(())
    }

    /// Puts every file in place, or none.
    fn place(self) -> Result<Vec<PathBuf>, CertError> {
        let mut placed: Vec<PathBuf> = Vec::new();
        for (aside, target) in &self.files {
            if let Err(e) = std::fs::hard_link(aside, target) {
                for p in &placed {
                    let _ = std::fs::remove_file(p);
                }
                if e.kind() == std::io::ErrorKind::AlreadyExists {
                    // Taken since the check: say by what.
                    refuse_existing(target)?;
                }
                return Err(format!(
                    "cannot create {}: {e} (nothing was written)",
                    target.display()
                )
                .into());
            }
            placed.push(target.clone());
        }
        Ok(placed)
    }
}

impl Drop for Aside {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Certificates are valid from the start of this year for two years: long enough for a
/// campaign, short enough that a lost key does not stay good for ever.
fn validity(p: &mut CertificateParams) {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let year = 1970 + (secs / 31_556_952) as i32;
    p.not_before = rcgen::date_time_ymd(year, 1, 1);
    p.not_after = rcgen::date_time_ymd(year + 2, 1, 1);
}

fn leaf(
    issuer: &Issuer<'_, KeyPair>,
    common_name: &str,
    sans: Vec<String>,
    server: bool,
) -> Result<(String, String), CertError> {
    let key = KeyPair::generate()?;
    let mut p = CertificateParams::new(sans)?;
    p.distinguished_name.push(DnType::CommonName, common_name);
    p.is_ca = IsCa::ExplicitNoCa;
    p.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    // The world is the TLS server of the link and a client of nobody; hosts the reverse.
    p.extended_key_usages = vec![if server {
        ExtendedKeyUsagePurpose::ServerAuth
    } else {
        ExtendedKeyUsagePurpose::ClientAuth
    }];
    validity(&mut p);
    let cert = p.signed_by(&key, issuer)?;
    Ok((cert.pem(), key.serialize_pem()))
}

/// Every file [`generate`] writes into `out`, with its mode.
fn targets(file: &HostsFile, out: &Path) -> Vec<(PathBuf, u32)> {
    let (wc, wk) = world_pair(out);
    let mut t = vec![
        (ca_cert(out), 0o644),
        (out.join("ca.key"), 0o600),
        (wc, 0o644),
        (wk, 0o600),
    ];
    for h in &file.hosts {
        let (c, k) = host_pair(out, &h.name);
        t.push((c, 0o644));
        t.push((k, 0o600));
    }
    t
}

/// Makes the CA, the world's and every host's certificate and key of `file` in `out`;
/// returns the files written. Refuses to overwrite anything, and writes nothing at all when
/// any target already exists or is a symbolic link: every target is checked before anything
/// is made, and the files are written aside and put in place together ([`Aside`]).
pub fn generate(file: &HostsFile, out: &Path) -> Result<Vec<PathBuf>, CertError> {
    let targets = targets(file, out);
    for (path, _) in &targets {
        refuse_existing(path)?;
    }
    let mut texts = Vec::new();
    let ca_key = KeyPair::generate()?;
    let mut p = CertificateParams::new(Vec::<String>::new())?;
    p.distinguished_name
        .push(DnType::CommonName, "swarmrt run CA");
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    validity(&mut p);
    let ca = p.self_signed(&ca_key)?;
    texts.push(ca.pem());
    texts.push(ca_key.serialize_pem());
    let issuer = Issuer::new(p, ca_key);
    let (cert, key) = leaf(&issuer, "world", world_names(file), true)?;
    texts.push(cert);
    texts.push(key);
    for h in &file.hosts {
        let (cert, key) = leaf(&issuer, &h.name, Vec::new(), false)?;
        texts.push(cert);
        texts.push(key);
    }
    let created = !out.exists();
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let written = Aside::new(out).and_then(|mut aside| {
        for ((path, mode), text) in targets.into_iter().zip(&texts) {
            aside.write(path, text, mode)?;
        }
        aside.place()
    });
    if written.is_err() && created {
        // Ours and empty again: nothing half-made is left, not even the directory.
        let _ = std::fs::remove_dir(out);
    }
    written
}

fn read_cert(path: &Path) -> Result<Vec<u8>, String> {
    let text = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let (_, pem) = x509_parser::pem::parse_x509_pem(&text)
        .map_err(|e| format!("{}: not a PEM certificate: {e}", path.display()))?;
    Ok(pem.contents)
}

/// The common name a certificate file names (a host checks its own before connecting: the
/// world's access control would drop everything a host with another's certificate says).
pub fn common_name(path: &Path) -> Result<String, String> {
    let der = read_cert(path)?;
    let (_, c) = X509Certificate::from_der(&der)
        .map_err(|_| format!("{}: not a valid X.509 certificate", path.display()))?;
    Ok(c.subject()
        .iter_common_name()
        .next()
        .and_then(|n| n.as_str().ok())
        .unwrap_or("")
        .to_string())
}

/// Checks one certificate against the CA: readable, signed by it, valid now, with a common
/// name `cn`, carrying every name in `names`, with `key` its private key.
fn check_pair(
    ca: Option<&X509Certificate>,
    cert: &Path,
    key: &Path,
    cn: &str,
    names: &[String],
    problems: &mut Vec<String>,
) {
    let der = match read_cert(cert) {
        Ok(d) => d,
        Err(e) => return problems.push(e),
    };
    let Ok((_, c)) = X509Certificate::from_der(&der) else {
        return problems.push(format!("{}: not a valid X.509 certificate", cert.display()));
    };
    let shown = cert.display();
    if let Some(ca) = ca
        && c.verify_signature(Some(ca.public_key())).is_err()
    {
        problems.push(format!("{shown}: not signed by the run's CA"));
    }
    if !c.validity().is_valid() {
        problems.push(format!(
            "{shown}: not valid now (valid {} to {})",
            c.validity().not_before,
            c.validity().not_after
        ));
    }
    let found = c
        .subject()
        .iter_common_name()
        .next()
        .and_then(|n| n.as_str().ok())
        .unwrap_or("");
    if found != cn {
        problems.push(format!("{shown}: names {found:?}, expected {cn:?}"));
    }
    let sans: Vec<String> = match c.subject_alternative_name() {
        Ok(Some(ext)) => ext
            .value
            .general_names
            .iter()
            .filter_map(|g| match g {
                GeneralName::DNSName(d) => Some(d.to_string()),
                GeneralName::IPAddress(ip) => match ip.len() {
                    4 => Some(std::net::Ipv4Addr::new(ip[0], ip[1], ip[2], ip[3]).to_string()),
                    16 => <[u8; 16]>::try_from(*ip)
                        .ok()
                        .map(|b| std::net::Ipv6Addr::from(b).to_string()),
                    _ => None,
                },
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    };
    for n in names {
        if !sans.contains(n) {
            problems.push(format!(
                "{shown}: does not name {n:?}, an address hosts connect to (run swarm certs again)"
            ));
        }
    }
    match std::fs::read_to_string(key) {
        Err(e) => problems.push(format!("{}: cannot read: {e}", key.display())),
        Ok(text) => match KeyPair::from_pem(&text) {
            Err(e) => problems.push(format!("{}: not a private key: {e}", key.display())),
            Ok(k) if k.subject_public_key_info() != c.public_key().raw => {
                problems.push(format!("{}: is not the key of {shown}", key.display()))
            }
            Ok(_) => {}
        },
    }
}

/// Everything wrong with `file`'s certificates, one line each; empty when a secure run can
/// start. A host's files are checked where its `certs` directory exists on this machine.
pub fn check(file: &HostsFile) -> Vec<String> {
    let mut problems = Vec::new();
    if !file.is_secure() {
        return problems;
    }
    let ca_der = read_cert(&ca_cert(&file.certs));
    let ca = match &ca_der {
        Ok(der) => X509Certificate::from_der(der).ok().map(|(_, c)| c),
        Err(e) => {
            problems.push(e.clone());
            None
        }
    };
    let (c, k) = world_pair(&file.certs);
    check_pair(
        ca.as_ref(),
        &c,
        &k,
        "world",
        &world_names(file),
        &mut problems,
    );
    for h in &file.hosts {
        if !h.certs.is_dir() {
            continue;
        }
        let (c, k) = host_pair(&h.certs, &h.name);
        check_pair(ca.as_ref(), &c, &k, &h.name, &[], &mut problems);
    }
    problems
}
