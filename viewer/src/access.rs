//! Who may talk to the viewer. Every request must name the viewer in its `Host` header (a
//! DNS-rebinding page on evil.com that resolves to 127.0.0.1 still says `Host: evil.com`),
//! must not come from another origin, and, when the viewer listens beyond loopback, must carry
//! the viewer's token: in the query (`?token=`, as in the URL it prints) or in the cookie the
//! viewer sets on the answer to such a request, which the page's own requests then carry.
//!
//! [`Access::check`] is a pure decision on a request's URI and headers; the server applies it
//! to every request before routing.

use std::io::Read;
use std::net::{IpAddr, Ipv6Addr, SocketAddr};

use axum::http::{HeaderMap, StatusCode, Uri, header};

/// Bytes of randomness in a token (printed as twice as many hex digits).
const TOKEN_BYTES: usize = 24;

/// What the server does with a request.
#[derive(Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Serve it; add `Set-Cookie: <value>` to the answer when given (a request that carried
    /// the token in its query, so the page's later requests carry it in the cookie).
    Allow {
        /// The cookie to set.
        set_cookie: Option<String>,
    },
    /// Answer with this status and line, and nothing of the run.
    Refuse(StatusCode, String),
}

/// The viewer's rules, fixed when it binds.
#[derive(Debug, Clone)]
pub struct Access {
    port: u16,
    /// Host names (lower case; IPv6 addresses in brackets) a request may name.
    names: Vec<String>,
    /// Any IP address literal may be named (the viewer listens on every address). An address
    /// cannot be rebound the way a DNS name can, so naming one is never a rebinding.
    any_ip: bool,
    token: Option<String>,
}

/// An IP address as it appears in a URL's authority.
fn literal(ip: IpAddr) -> String {
    match ip {
        IpAddr::V6(v6) => format!("[{v6}]"),
        IpAddr::V4(v4) => v4.to_string(),
    }
}

/// `host[:port]` split into its lower-case host and its port (80 when absent); `None` when it
/// is not an authority.
fn authority(text: &str) -> Option<(String, u16)> {
    let (host, port) = if let Some(rest) = text.strip_prefix('[') {
        let close = rest.find(']')?;
        let host = &text[..close + 2];
        (host, &rest[close + 1..])
    } else {
        match text.rfind(':') {
            Some(at) => (&text[..at], &text[at..]),
            None => (text, ""),
        }
    };
    let port = match port {
        "" => 80,
        p => p.strip_prefix(':')?.parse().ok()?,
    };
    if host.is_empty() {
        return None;
    }
    Some((host.to_ascii_lowercase(), port))
}

fn is_ip_literal(host: &str) -> bool {
    match host.strip_prefix('[').and_then(|h| h.strip_suffix(']')) {
        Some(v6) => v6.parse::<Ipv6Addr>().is_ok(),
        None => host.parse::<std::net::Ipv4Addr>().is_ok(),
    }
}

/// Equal bytes, compared in time that does not depend on where they differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A fresh random token (hex), from the kernel's generator.
pub fn new_token() -> std::io::Result<String> {
    let mut bytes = [0u8; TOKEN_BYTES];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// This machine's host name, if it has one (`/proc/sys/kernel/hostname`).
pub fn host_name() -> Option<String> {
    let name = std::fs::read_to_string("/proc/sys/kernel/hostname").ok()?;
    let name = name.trim().to_ascii_lowercase();
    (!name.is_empty() && name != "localhost").then_some(name)
}

impl Access {
    /// The rules for a viewer bound to `addr`: on loopback, the loopback names and no token;
    /// beyond it, `addr` itself (any address literal when `addr` is unspecified), the host's
    /// `name`, and `token` on every request.
    pub fn new(addr: SocketAddr, name: Option<String>, token: Option<String>) -> Access {
        let ip = addr.ip();
        let mut names = vec!["localhost".to_string()];
        let mut any_ip = false;
        if ip.is_loopback() {
            names.extend(["127.0.0.1".to_string(), "[::1]".to_string()]);
            names.push(literal(ip));
        } else {
            if ip.is_unspecified() {
                any_ip = true;
            } else {
                names.push(literal(ip));
            }
            names.extend(name);
        }
        names.dedup();
        Access {
            port: addr.port(),
            names,
            any_ip,
            token,
        }
    }

    /// The token requests must carry, if the viewer listens beyond loopback.
    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// The cookie that carries the token (one name per port: cookies do not tell ports apart).
    fn cookie_name(&self) -> String {
        format!("swarmrt-view-{}", self.port)
    }

    fn names_ok(&self, host: &str, port: u16) -> bool {
        port == self.port
            && (self.names.iter().any(|n| n == host) || (self.any_ip && is_ip_literal(host)))
    }

    fn misdirected(&self, what: &str) -> Verdict {
        let names: Vec<String> = self
            .names
            .iter()
            .map(|n| format!("{n}:{}", self.port))
            .collect();
        let also = if self.any_ip {
            " or any of this host's addresses"
        } else {
            ""
        };
        Verdict::Refuse(
            StatusCode::MISDIRECTED_REQUEST,
            format!(
                "swarm view answers only to its own address ({}{also}); {what}\n",
                names.join(", ")
            ),
        )
    }

    /// Whether the request with `uri` and `headers` may be served.
    pub fn check(&self, uri: &Uri, headers: &HeaderMap) -> Verdict {
        let Some(host) = headers
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .and_then(authority)
        else {
            return self.misdirected("the request names none");
        };
        if !self.names_ok(&host.0, host.1) {
            return self.misdirected("the request names another");
        }
        // A request in absolute form names its host in the URI too.
        if let Some(a) = uri.authority() {
            match authority(a.as_str()) {
                Some(named) if named == host => {}
                _ => return self.misdirected("the request names another"),
            }
        }
        if let Some(origin) = headers.get(header::ORIGIN) {
            let own = origin
                .to_str()
                .ok()
                .and_then(|o| o.strip_prefix("http://"))
                .and_then(authority);
            if own.as_ref() != Some(&host) {
                return Verdict::Refuse(
                    StatusCode::FORBIDDEN,
                    "swarm view answers only its own page (the request comes from another origin)\n"
                        .into(),
                );
            }
        }
        // A subresource of another site's page (an <img> or <script> pointing here) sends no
        // Origin; the browser says where it comes from instead.
        if uri.path().starts_with("/api/") {
            let site = headers.get("sec-fetch-site").and_then(|v| v.to_str().ok());
            if matches!(site, Some(s) if s != "same-origin" && s != "none") {
                return Verdict::Refuse(
                    StatusCode::FORBIDDEN,
                    "swarm view answers only its own page (the request comes from another site)\n"
                        .into(),
                );
            }
        }
        let Some(token) = &self.token else {
            return Verdict::Allow { set_cookie: None };
        };
        let in_query = uri
            .query()
            .into_iter()
            .flat_map(|q| q.split('&'))
            .filter_map(|kv| kv.strip_prefix("token="))
            .any(|t| same(t.as_bytes(), token.as_bytes()));
        if in_query {
            return Verdict::Allow {
                set_cookie: Some(format!(
                    "{}={token}; Path=/; HttpOnly; SameSite=Strict",
                    self.cookie_name()
                )),
            };
        }
        let name = self.cookie_name();
        let in_cookie = headers
            .get_all(header::COOKIE)
            .iter()
            .filter_map(|v| v.to_str().ok())
            .flat_map(|v| v.split(';'))
            .filter_map(|kv| kv.trim().split_once('='))
            .any(|(k, v)| k == name && same(v.as_bytes(), token.as_bytes()));
        if in_cookie {
            return Verdict::Allow { set_cookie: None };
        }
        Verdict::Refuse(
            StatusCode::FORBIDDEN,
            "swarm view listens beyond loopback and needs its token: open the URL it printed \
             (it ends in ?token=...)\n"
                .into(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(uri: &str, headers: &[(&str, &str)]) -> (Uri, HeaderMap) {
        let mut map = HeaderMap::new();
        for (k, v) in headers {
            map.append(
                axum::http::HeaderName::from_bytes(k.as_bytes()).unwrap(),
                v.parse().unwrap(),
            );
        }
        (uri.parse().unwrap(), map)
    }

    fn verdict(access: &Access, uri: &str, headers: &[(&str, &str)]) -> Verdict {
        let (uri, headers) = request(uri, headers);
        access.check(&uri, &headers)
    }

    fn status(v: Verdict) -> u16 {
        match v {
            Verdict::Allow { .. } => 200,
            Verdict::Refuse(code, _) => code.as_u16(),
        }
    }

    #[test]
    fn loopback_answers_its_own_names_only_and_never_another_origin() {
        let a = Access::new("127.0.0.1:8123".parse().unwrap(), None, None);
        for host in [
            "127.0.0.1:8123",
            "localhost:8123",
            "[::1]:8123",
            "LOCALHOST:8123",
        ] {
            assert_eq!(
                status(verdict(&a, "/api/meta", &[("host", host)])),
                200,
                "{host}"
            );
        }
        for host in [
            "evil.com:8123",
            "127.0.0.1:8124",
            "127.0.0.1",
            "localhost.:8123",
            "10.0.0.1:8123",
            "",
        ] {
            assert_eq!(
                status(verdict(&a, "/api/meta", &[("host", host)])),
                421,
                "{host:?}"
            );
        }
        assert_eq!(status(verdict(&a, "/", &[])), 421, "no Host");
        assert_eq!(
            status(verdict(
                &a,
                "http://evil.com:8123/api/meta",
                &[("host", "127.0.0.1:8123")]
            )),
            421
        );
        let own = [
            ("host", "127.0.0.1:8123"),
            ("origin", "http://127.0.0.1:8123"),
        ];
        assert_eq!(status(verdict(&a, "/api/live", &own)), 200);
        for origin in [
            "http://evil.com",
            "null",
            "http://localhost:8123",
            "https://127.0.0.1:8123",
        ] {
            let h = [("host", "127.0.0.1:8123"), ("origin", origin)];
            assert_eq!(
                status(verdict(&a, "/api/frames?from=0&to=1", &h)),
                403,
                "{origin}"
            );
        }
        let cross = [("host", "127.0.0.1:8123"), ("sec-fetch-site", "cross-site")];
        assert_eq!(status(verdict(&a, "/api/robot?id=0&frame=0", &cross)), 403);
        assert_eq!(
            status(verdict(&a, "/", &cross)),
            200,
            "a link from elsewhere opens the page"
        );
        let typed = [("host", "127.0.0.1:8123"), ("sec-fetch-site", "none")];
        assert_eq!(status(verdict(&a, "/api/meta", &typed)), 200);
    }

    #[test]
    fn beyond_loopback_the_token_is_asked_of_every_request() {
        let token = new_token().unwrap();
        assert_eq!(token.len(), 2 * TOKEN_BYTES);
        assert_ne!(token, new_token().unwrap());
        let a = Access::new(
            "0.0.0.0:9000".parse().unwrap(),
            Some("rack-a".into()),
            Some(token.clone()),
        );
        let host = [("host", "10.1.2.3:9000")];
        assert_eq!(status(verdict(&a, "/", &host)), 403);
        assert_eq!(status(verdict(&a, "/?token=0123", &host)), 403);
        let Verdict::Allow {
            set_cookie: Some(cookie),
        } = verdict(&a, &format!("/?token={token}"), &host)
        else {
            panic!("the printed URL opens the page");
        };
        assert_eq!(
            cookie,
            format!("swarmrt-view-9000={token}; Path=/; HttpOnly; SameSite=Strict")
        );
        let jar = format!("other=1; swarmrt-view-9000={token}");
        for host in [
            "10.1.2.3:9000",
            "rack-a:9000",
            "[fe80::1]:9000",
            "localhost:9000",
        ] {
            let h = [("host", host), ("cookie", jar.as_str())];
            assert_eq!(status(verdict(&a, "/api/meta", &h)), 200, "{host}");
        }
        let wrong = [("host", "10.1.2.3:9000"), ("cookie", "swarmrt-view-9001=x")];
        assert_eq!(status(verdict(&a, "/api/meta", &wrong)), 403);
        let evil = [("host", "evil.com:9000"), ("cookie", jar.as_str())];
        assert_eq!(status(verdict(&a, "/api/meta", &evil)), 421);

        let one = Access::new("10.1.2.3:9000".parse().unwrap(), None, Some(token.clone()));
        let ok = format!("/api/meta?token={token}");
        assert_eq!(
            status(verdict(&one, &ok, &[("host", "10.1.2.3:9000")])),
            200
        );
        assert_eq!(
            status(verdict(&one, &ok, &[("host", "10.1.2.4:9000")])),
            421
        );
    }
}
