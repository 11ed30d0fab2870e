//! Who may use the host port, with what rights, and for how long (docs/protocol.md
//! "Connections"): the `[host]` configuration made into the rules the Ethernet task applies
//! to each TCP connection. Pure rules (no sockets, no clock): [`HostAccess::rights`] for a
//! peer, [`HostAccess::idle`] for a silent connection; [`check_exposure`] and [`read_token`]
//! run once at start-up.
//!
//! ```
//! use wrc_config::HostConfig;
//! use wrc_controller::host_access::{HostAccess, Rights};
//!
//! let config = HostConfig {
//!     allow: vec!["192.168.1.0/24".parse().unwrap()],
//!     monitor: vec!["10.0.0.0/8".parse().unwrap()],
//!     ..HostConfig::default()
//! };
//! let access = HostAccess::new(&config, None);
//! assert_eq!(access.rights("127.0.0.1".parse().unwrap()), Some(Rights::Command));
//! assert_eq!(access.rights("192.168.1.7".parse().unwrap()), Some(Rights::Command));
//! assert_eq!(access.rights("10.2.3.4".parse().unwrap()), Some(Rights::Monitor));
//! assert_eq!(access.rights("172.16.0.1".parse().unwrap()), None);
//! ```

use std::net::{IpAddr, SocketAddr};
use std::path::Path;

use wrc_config::{HostConfig, IpNet};
use wrc_protocol::AuthToken;

/// Wrong tokens a connection may send before it is closed.
pub const MAX_AUTH_FAILURES: u8 = 3;

/// What a connection may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rights {
    /// Every verb (control still decides who moves the robot).
    Command,
    /// Read-only verbs only, whatever it sends.
    Monitor,
    /// Read-only verbs until `AUTH` with the control token, then [`Rights::Command`].
    Token,
}

/// The host port's admission rules.
#[derive(Debug, Clone)]
pub struct HostAccess {
    /// TCP connections one address may hold.
    pub max_per_address: usize,
    /// Silence after which a connection without control or subscription is closed [ns];
    /// `None`: never.
    pub idle_timeout_ns: Option<u64>,
    allow: Vec<IpNet>,
    monitor: Vec<IpNet>,
    token: Option<AuthToken>,
}

impl HostAccess {
    /// The rules of `config`, with the control token read from its `token_file`.
    pub fn new(config: &HostConfig, token: Option<AuthToken>) -> HostAccess {
        let idle_ns = (config.idle_timeout_s * 1e9).round();
        HostAccess {
            max_per_address: config.max_per_address,
            idle_timeout_ns: (idle_ns >= 1.0).then_some(idle_ns as u64),
            allow: config.allow.clone(),
            monitor: config.monitor.clone(),
            token,
        }
    }

    /// What a connection from `peer` may do; `None`: it may not connect.
    ///
    /// Loopback may always command. An address in `allow` may command, after `AUTH` when a
    /// token is configured; one in `monitor` only monitors. With neither list (a port
    /// guarded by the token alone) every address may connect and commands after `AUTH`.
    pub fn rights(&self, peer: IpAddr) -> Option<Rights> {
        let peer = wrc_config::canonical(peer);
        let commands = if self.token.is_some() {
            Rights::Token
        } else {
            Rights::Command
        };
        if peer.is_loopback() {
            Some(Rights::Command)
        } else if wrc_config::listed(&self.allow, peer) {
            Some(commands)
        } else if wrc_config::listed(&self.monitor, peer) {
            Some(Rights::Monitor)
        } else if self.allow.is_empty() && self.monitor.is_empty() && self.token.is_some() {
            Some(Rights::Token)
        } else {
            None
        }
    }

    /// Whether a control token is configured.
    pub fn has_token(&self) -> bool {
        self.token.is_some()
    }

    /// Whether `token` is the control token (always `false` when none is configured).
    pub fn token_matches(&self, token: &AuthToken) -> bool {
        self.token.as_ref().is_some_and(|t| t.matches(token))
    }

    /// Whether a connection last active at `last_ns` is idle at `now_ns` [ns].
    pub fn idle(&self, last_ns: u64, now_ns: u64) -> bool {
        self.idle_timeout_ns
            .is_some_and(|limit| now_ns.saturating_sub(last_ns) >= limit)
    }
}

/// Why the host port may not open as configured.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AccessError {
    /// Bound off loopback with nothing to say who may connect.
    #[error(
        "the host port {addr} is reachable from the network, but the configuration does not \
         say who may use it: list the hosts in [host] allow = [\"192.168.1.20\", …] (and \
         read-only ones in monitor = […]) and/or set [host] token_file, or bind 127.0.0.1"
    )]
    Unguarded {
        /// The address asked for.
        addr: SocketAddr,
    },
    /// The token file cannot be read.
    #[error("cannot read the control token file {file}: {reason}")]
    TokenRead {
        /// The file.
        file: String,
        /// Why.
        reason: std::io::Error,
    },
    /// The token file may be read by others than its owner.
    #[error(
        "the control token file {file} may be read by other users (mode {mode:o}): \
         chmod 600 it"
    )]
    TokenExposed {
        /// The file.
        file: String,
        /// Its permission bits.
        mode: u32,
    },
    /// The process may not open a descriptor for every connection.
    #[error(
        "[host] max_connections needs {need} file descriptors but this process may open \
         {limit}: lower max_connections or raise the limit (ulimit -Hn)"
    )]
    Descriptors {
        /// Descriptors needed.
        need: u64,
        /// The hard limit.
        limit: u64,
    },
    /// The token file does not hold a usable token.
    #[error(
        "the control token file {file} must hold one token of 16-64 letters, digits, _ or - \
         (e.g. tr -dc A-Za-z0-9 </dev/urandom | head -c 32 > {file})"
    )]
    TokenFormat {
        /// The file.
        file: String,
    },
}

/// Make sure the process may hold `need` file descriptors: raise its soft limit up to its
/// hard one when it is lower (once, at start-up), so accepting a connection never fails for
/// want of one while the slots allow it.
pub fn reserve_descriptors(need: usize) -> Result<(), AccessError> {
    let need = need as libc::rlim_t;
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes the struct it is given, which lives for the call.
    if unsafe { libc::getrlimit(libc::RLIMIT_NOFILE, &mut limit) } != 0 || limit.rlim_cur >= need {
        return Ok(());
    }
    if limit.rlim_max < need {
        return Err(AccessError::Descriptors {
            need: wide(need),
            limit: wide(limit.rlim_max),
        });
    }
    limit.rlim_cur = need;
    // SAFETY: setrlimit reads the struct it is given, which lives for the call.
    if unsafe { libc::setrlimit(libc::RLIMIT_NOFILE, &limit) } != 0 {
        return Err(AccessError::Descriptors {
            need: wide(need),
            limit: wide(limit.rlim_max),
        });
    }
    Ok(())
}

/// A resource limit as a `u64` (`rlim_t` is narrower on some targets).
#[allow(clippy::unnecessary_cast)]
fn wide(value: libc::rlim_t) -> u64 {
    value as u64
}

/// Refuse a host port bound off loopback unless the configuration says who may use it.
pub fn check_exposure(addr: SocketAddr, config: &HostConfig) -> Result<(), AccessError> {
    if wrc_config::canonical(addr.ip()).is_loopback() || config.guards_the_network() {
        Ok(())
    } else {
        Err(AccessError::Unguarded { addr })
    }
}

/// The control token in `path`: one line of 16-64 letters, digits, `_` or `-`, in a file
/// only its owner may read.
pub fn read_token(path: &Path) -> Result<AuthToken, AccessError> {
    use std::os::unix::fs::PermissionsExt;
    let file = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|reason| AccessError::TokenRead {
        file: file.clone(),
        reason,
    })?;
    let mode = meta.permissions().mode() & 0o777;
    if mode & 0o077 != 0 {
        return Err(AccessError::TokenExposed { file, mode });
    }
    let text = std::fs::read_to_string(path).map_err(|reason| AccessError::TokenRead {
        file: file.clone(),
        reason,
    })?;
    AuthToken::new(text.trim()).ok_or(AccessError::TokenFormat { file })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn ip(text: &str) -> IpAddr {
        text.parse().unwrap()
    }

    fn token() -> AuthToken {
        AuthToken::new("s3cret-token-0123456789").unwrap()
    }

    #[test]
    fn a_token_makes_allowed_hosts_authenticate_and_monitors_stay_read_only() {
        let config = HostConfig {
            allow: vec!["192.168.1.0/24".parse().unwrap()],
            monitor: vec!["10.0.0.0/8".parse().unwrap()],
            ..HostConfig::default()
        };
        let access = HostAccess::new(&config, Some(token()));
        assert_eq!(access.rights(ip("::1")), Some(Rights::Command));
        assert_eq!(access.rights(ip("192.168.1.7")), Some(Rights::Token));
        assert_eq!(access.rights(ip("::ffff:192.168.1.7")), Some(Rights::Token));
        assert_eq!(access.rights(ip("10.2.3.4")), Some(Rights::Monitor));
        assert_eq!(access.rights(ip("172.16.0.1")), None);
        assert!(access.token_matches(&token()));
        assert!(!access.token_matches(&AuthToken::new("s3cret-token-0123456780").unwrap()));
        assert!(!access.token_matches(&AuthToken::new("s3cret-token-01234567").unwrap()));
    }

    #[test]
    fn a_token_alone_lets_any_address_monitor_and_command_after_auth() {
        let access = HostAccess::new(&HostConfig::default(), Some(token()));
        assert_eq!(access.rights(ip("172.16.0.1")), Some(Rights::Token));
        let open = HostAccess::new(&HostConfig::default(), None);
        assert_eq!(open.rights(ip("172.16.0.1")), None);
        assert!(!open.token_matches(&token()));
    }

    #[test]
    fn idle_means_silent_for_the_whole_timeout_and_zero_means_never() {
        let access = HostAccess::new(
            &HostConfig {
                idle_timeout_s: 2.0,
                ..HostConfig::default()
            },
            None,
        );
        assert!(!access.idle(1_000, 2_000_000_999));
        assert!(access.idle(1_000, 2_000_001_000));
        let never = HostAccess::new(
            &HostConfig {
                idle_timeout_s: 0.0,
                ..HostConfig::default()
            },
            None,
        );
        assert!(!never.idle(0, u64::MAX));
    }

    #[test]
    fn only_a_guarded_configuration_may_bind_off_loopback() {
        let open = HostConfig::default();
        for local in ["127.0.0.1:7100", "[::1]:7100", "127.0.0.2:7100"] {
            assert!(
                check_exposure(local.parse().unwrap(), &open).is_ok(),
                "{local}"
            );
        }
        let e = check_exposure("0.0.0.0:7100".parse().unwrap(), &open).unwrap_err();
        assert!(e.to_string().contains("[host] allow"), "{e}");
        let guarded = HostConfig {
            monitor: vec!["10.0.0.0/8".parse().unwrap()],
            ..HostConfig::default()
        };
        assert!(check_exposure("0.0.0.0:7100".parse().unwrap(), &guarded).is_ok());
    }

    #[test]
    fn a_token_file_must_be_private_and_hold_one_token() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("token");
        std::fs::write(&path, "s3cret-token-0123456789\n").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let e = read_token(&path).unwrap_err();
        assert!(e.to_string().contains("chmod 600"), "{e}");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
        assert!(read_token(&path).unwrap().matches(&token()));
        std::fs::write(&path, "short\n").unwrap();
        let e = read_token(&path).unwrap_err();
        assert!(e.to_string().contains("16-64"), "{e}");
        let e = read_token(&dir.path().join("missing")).unwrap_err();
        assert!(e.to_string().contains("cannot read"), "{e}");
    }
}
