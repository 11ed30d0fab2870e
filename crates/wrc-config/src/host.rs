//! The host port's admission (`[host]`): how many TCP connections the controller serves, how
//! many one address may hold, how long a connection without control may stay silent, and,
//! when the port is bound off loopback, which addresses may connect (to command, or only to
//! monitor) and the file holding the control token (docs/protocol.md "Connections").

use std::net::IpAddr;
use std::path::PathBuf;

use ipnet::IpNet;
use serde::Deserialize;

use crate::ConfigError;

/// Most TCP connections a controller may be configured to serve.
pub const MAX_CONNECTIONS: usize = 1024;

/// The host port's admission settings.
#[derive(Debug, Clone, PartialEq)]
pub struct HostConfig {
    /// TCP connections served at once (1 to [`MAX_CONNECTIONS`]).
    pub max_connections: usize,
    /// TCP connections one peer address may hold at once (1 to `max_connections`).
    pub max_per_address: usize,
    /// A connection that holds no control, does not subscribe and sends no request for this
    /// long is told `EVT CLOSING IDLE` and closed [s]; 0: never.
    pub idle_timeout_s: f64,
    /// Addresses (or networks) that may connect and command, besides loopback.
    pub allow: Vec<IpNet>,
    /// Addresses (or networks) that may connect to monitor only (read-only verbs).
    pub monitor: Vec<IpNet>,
    /// The file holding the control token (16-64 letters, digits, `_` or `-`, readable by
    /// its owner only); connections from off the machine then command only after
    /// `AUTH <token>`. Relative to the working directory.
    pub token_file: Option<PathBuf>,
}

impl Default for HostConfig {
    fn default() -> Self {
        HostConfig {
            max_connections: 256,
            max_per_address: 64,
            idle_timeout_s: 600.0,
            allow: Vec::new(),
            monitor: Vec::new(),
            token_file: None,
        }
    }
}

impl HostConfig {
    /// Whether an off-loopback port is protected: the configuration names the addresses
    /// that may connect, or a token for control.
    pub fn guards_the_network(&self) -> bool {
        !self.allow.is_empty() || !self.monitor.is_empty() || self.token_file.is_some()
    }
}

/// Whether `addr` is in one of `nets` (an IPv4 peer seen through an IPv6 socket as
/// `::ffff:a.b.c.d` is matched as IPv4).
pub fn listed(nets: &[IpNet], addr: IpAddr) -> bool {
    let addr = canonical(addr);
    nets.iter().any(|n| n.contains(&addr))
}

/// `addr` with an IPv4-mapped IPv6 address turned into IPv4.
pub fn canonical(addr: IpAddr) -> IpAddr {
    match addr {
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(IpAddr::V6(v6), IpAddr::V4),
        v4 => v4,
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct RawHost {
    max_connections: i64,
    max_per_address: i64,
    idle_timeout_s: f64,
    allow: Vec<String>,
    monitor: Vec<String>,
    token_file: Option<PathBuf>,
}

impl Default for RawHost {
    fn default() -> Self {
        let d = HostConfig::default();
        RawHost {
            max_connections: d.max_connections as i64,
            max_per_address: d.max_per_address as i64,
            idle_timeout_s: d.idle_timeout_s,
            allow: Vec::new(),
            monitor: Vec::new(),
            token_file: None,
        }
    }
}

impl RawHost {
    pub(crate) fn into_host(self, file: &str) -> Result<HostConfig, ConfigError> {
        let invalid = |key: &str, reason: String| ConfigError::Invalid {
            file: file.to_string(),
            key: format!("host.{key}"),
            reason,
        };
        if !(1..=MAX_CONNECTIONS as i64).contains(&self.max_connections) {
            return Err(invalid(
                "max_connections",
                format!(
                    "{} is out of range: use 1 to {MAX_CONNECTIONS} connections",
                    self.max_connections
                ),
            ));
        }
        if !(1..=self.max_connections).contains(&self.max_per_address) {
            return Err(invalid(
                "max_per_address",
                format!(
                    "{} is out of range: use 1 to max_connections ({})",
                    self.max_per_address, self.max_connections
                ),
            ));
        }
        if !(self.idle_timeout_s.is_finite() && self.idle_timeout_s >= 0.0) {
            return Err(invalid(
                "idle_timeout_s",
                format!(
                    "{} is not a time: use 0 (never) or a number of seconds",
                    self.idle_timeout_s
                ),
            ));
        }
        let nets = |key: &str, list: Vec<String>| -> Result<Vec<IpNet>, ConfigError> {
            list.iter()
                .map(|text| {
                    parse_net(text).ok_or_else(|| {
                        invalid(
                            key,
                            format!(
                                "\"{text}\" is not an address or a network \
                                 (e.g. \"192.168.1.20\", \"10.1.0.0/16\", \"fd00::/8\")"
                            ),
                        )
                    })
                })
                .collect()
        };
        if self
            .token_file
            .as_ref()
            .is_some_and(|p| p.as_os_str().is_empty())
        {
            return Err(invalid(
                "token_file",
                "is empty: name the file that holds the token, or leave the key out".into(),
            ));
        }
        Ok(HostConfig {
            max_connections: self.max_connections as usize,
            max_per_address: self.max_per_address as usize,
            idle_timeout_s: self.idle_timeout_s,
            allow: nets("allow", self.allow)?,
            monitor: nets("monitor", self.monitor)?,
            token_file: self.token_file,
        })
    }
}

/// `"10.1.0.0/16"`, `"fd00::/8"` or a bare address (one host), as `[host] allow` and
/// `monitor` take them.
pub fn parse_net(text: &str) -> Option<IpNet> {
    let text = text.trim();
    text.parse::<IpNet>()
        .ok()
        .or_else(|| text.parse::<IpAddr>().ok().map(IpNet::from))
        .map(|n| n.trunc())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ip(text: &str) -> IpAddr {
        text.parse().unwrap()
    }

    #[test]
    fn networks_and_bare_addresses_match_their_peers() {
        let nets = vec![
            parse_net("10.1.0.0/16").unwrap(),
            parse_net("192.168.1.20").unwrap(),
            parse_net("fd00::/8").unwrap(),
        ];
        assert!(listed(&nets, ip("10.1.200.3")));
        assert!(!listed(&nets, ip("10.2.0.1")));
        assert!(listed(&nets, ip("192.168.1.20")));
        assert!(!listed(&nets, ip("192.168.1.21")));
        assert!(listed(&nets, ip("fd12::1")));
        // An IPv4 peer on an IPv6 socket.
        assert!(listed(&nets, ip("::ffff:10.1.2.3")));
        assert!(!listed(&nets, ip("::ffff:10.9.2.3")));
        assert_eq!(parse_net("10.1.2.3/16"), parse_net("10.1.0.0/16"));
        for bad in ["", "10.1.0.0/33", "robot-1", "10.1/8x"] {
            assert_eq!(parse_net(bad), None, "{bad}");
        }
    }
}
