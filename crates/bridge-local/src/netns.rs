//! Two hosts on one machine for the bridge across hosts (tests and the
//! Zenoh benchmark): two network namespaces joined by a veth pair, created
//! as root and removed when dropped. Traffic goes only to the addresses
//! given here or to loopback (docs/bridge.md, "Across hosts").

use std::process::{Command, Output};
use std::sync::atomic::{AtomicU32, Ordering};

/// Namespaces `a` (the bridge's host) and `b` (the client's), joined by a
/// veth pair with the addresses `addr_a` and `addr_b` (a /24 of 10.200.0.0/13
/// chosen from the process id and a counter); both loopbacks up. Dropping it
/// deletes both namespaces (and with them the pair).
pub struct Hosts {
    /// The bridge's namespace.
    pub a: String,
    /// The client's namespace.
    pub b: String,
    /// The client's end of the pair (in `b`).
    pub veth_b: String,
    /// The bridge's address.
    pub addr_a: String,
    /// The client's address.
    pub addr_b: String,
}

/// Runs `args`; its output, or what failed.
fn run(args: &[&str]) -> Result<Output, String> {
    let out = Command::new(args[0])
        .args(&args[1..])
        .output()
        .map_err(|e| format!("{}: {e}", args.join(" ")))?;
    if out.status.success() {
        Ok(out)
    } else {
        Err(format!(
            "{}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// The effective user id (from /proc/self/status).
pub fn effective_uid() -> Option<u32> {
    std::fs::read_to_string("/proc/self/status")
        .ok()?
        .lines()
        .find_map(|l| l.strip_prefix("Uid:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|u| u.parse().ok())
}

impl Hosts {
    /// Creates the two namespaces and their link; an error (in words) when
    /// not root or when `ip` fails.
    pub fn new() -> Result<Hosts, String> {
        static NEXT: AtomicU32 = AtomicU32::new(0);
        if effective_uid() != Some(0) {
            return Err(
                "two hosts on one machine need network namespaces: run as root (CI does)".into(),
            );
        }
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let pid = std::process::id();
        let tag = format!("{}{}", pid % 100_000, n);
        let hosts = Hosts {
            a: format!("dzna{tag}"),
            b: format!("dznb{tag}"),
            veth_b: format!("dzvb{tag}"),
            addr_a: format!("10.{}.{}.1", 200 + n % 8, pid % 250),
            addr_b: format!("10.{}.{}.2", 200 + n % 8, pid % 250),
        };
        let veth_a = format!("dzva{tag}");
        run(&["ip", "netns", "add", &hosts.a])?;
        // From here on, dropping `hosts` deletes what exists.
        run(&["ip", "netns", "add", &hosts.b])?;
        run(&[
            "ip",
            "link",
            "add",
            &veth_a,
            "netns",
            &hosts.a,
            "type",
            "veth",
            "peer",
            "name",
            &hosts.veth_b,
            "netns",
            &hosts.b,
        ])?;
        for (ns, dev, addr) in [
            (&hosts.a, &veth_a, &hosts.addr_a),
            (&hosts.b, &hosts.veth_b, &hosts.addr_b),
        ] {
            run(&[
                "ip",
                "-n",
                ns,
                "addr",
                "add",
                &format!("{addr}/24"),
                "dev",
                dev,
            ])?;
            run(&["ip", "-n", ns, "link", "set", dev, "up"])?;
            run(&["ip", "-n", ns, "link", "set", "lo", "up"])?;
        }
        Ok(hosts)
    }

    /// `tcp/<addr_a>:<port>`: the bridge's endpoint.
    pub fn endpoint(&self, port: u16) -> String {
        format!("tcp/{}:{port}", self.addr_a)
    }

    /// `program` run in namespace `ns` (`ip netns exec NS PROGRAM`).
    pub fn exec(ns: &str, program: &std::path::Path) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", ns]).arg(program);
        c
    }

    /// Takes the client's end of the link down (`false`) or up again.
    pub fn link(&self, up: bool) -> Result<(), String> {
        run(&[
            "ip",
            "-n",
            &self.b,
            "link",
            "set",
            &self.veth_b,
            if up { "up" } else { "down" },
        ])
        .map(|_| ())
    }

    /// The local addresses of the listening TCP and UDP sockets in namespace
    /// `ns` (`ss -ltnuH`).
    pub fn listening(&self, ns: &str) -> Result<Vec<String>, String> {
        let out = run(&["ip", "netns", "exec", ns, "ss", "-ltnuH"])?;
        Ok(String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| l.split_whitespace().nth(4).map(str::to_owned))
            .collect())
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        for ns in [&self.a, &self.b] {
            let _ = Command::new("ip").args(["netns", "del", ns]).status();
        }
    }
}
