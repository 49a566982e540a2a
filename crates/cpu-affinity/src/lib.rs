//! # cpu-affinity: the CPUs a process runs on
//!
//! `decoy bridge --cpu` and `decoy feed --cpu` put the bridge and its client on
//! chosen cores (docs/bridge.md, "Cores"); the bridge's and the feed's
//! summaries report the CPUs they ran on ([`current_list`]).
//!
//! Why it matters for lockstep: a lockstep frame is two hand-offs (state to the
//! bridge, answer to the client). When the client and the bridge run on two
//! cores, each hand-off wakes a core that went idle while it waited; on a
//! virtual machine whose idle virtual CPUs halt (this project's CI machines:
//! `haltpoll` with `guest_halt_poll_ns = 0`) that wake-up costs tens to hundreds
//! of microseconds. On one core, the hand-off is a context switch. Which cores
//! a process runs on changes no bit of any answer.

#![deny(missing_docs)]

use std::fmt;

/// Why a CPU set was refused or could not be applied.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AffinityError {
    /// The list is malformed or names a CPU this process may not run on: the
    /// input must change (exit code 2).
    Usage(String),
    /// The operating system refused (exit code 1).
    System(String),
}

impl AffinityError {
    /// Whether the input must change (exit code 2) rather than the call failing (1).
    pub fn is_usage(&self) -> bool {
        matches!(self, AffinityError::Usage(_))
    }
}

impl fmt::Display for AffinityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AffinityError::Usage(m) | AffinityError::System(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for AffinityError {}

/// A non-empty set of CPU numbers, in Linux's list format: `0`, `0,2`, `0-3`,
/// `0-1,6`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cpus(Vec<usize>);

/// CPU numbers above this are refused (glibc's `cpu_set_t` holds 1,024).
const MAX_CPU: usize = 1023;

impl Cpus {
    /// Parses `text` (`--cpu`'s value).
    pub fn parse(text: &str) -> Result<Self, AffinityError> {
        let bad = |why: String| {
            AffinityError::Usage(format!(
                "--cpu {text:?}: {why} (expected CPU numbers such as 0, 0,2 or 0-3)"
            ))
        };
        let number = |s: &str| -> Result<usize, AffinityError> {
            let n: usize = s
                .trim()
                .parse()
                .map_err(|_| bad(format!("{:?} is not a CPU number", s.trim())))?;
            if n > MAX_CPU {
                return Err(bad(format!("CPU {n} is above {MAX_CPU}")));
            }
            Ok(n)
        };
        let mut cpus = Vec::new();
        for part in text.split(',') {
            if part.trim().is_empty() {
                return Err(bad("an empty item".to_owned()));
            }
            match part.split_once('-') {
                Some((a, b)) => {
                    let (a, b) = (number(a)?, number(b)?);
                    if a > b {
                        return Err(bad(format!("the range {a}-{b} runs backwards")));
                    }
                    cpus.extend(a..=b);
                }
                None => cpus.push(number(part)?),
            }
        }
        cpus.sort_unstable();
        cpus.dedup();
        Ok(Cpus(cpus))
    }

    /// The CPU numbers, ascending.
    pub fn list(&self) -> &[usize] {
        &self.0
    }

    /// The CPUs the calling thread may run on now.
    #[cfg(target_os = "linux")]
    pub fn of_this_thread() -> Result<Self, AffinityError> {
        use nix::sched::{CpuSet, sched_getaffinity};
        use nix::unistd::Pid;
        let set = sched_getaffinity(Pid::from_raw(0))
            .map_err(|e| AffinityError::System(format!("cannot read the CPU affinity: {e}")))?;
        let cpus: Vec<usize> = (0..CpuSet::count().min(MAX_CPU + 1))
            .filter(|&c| set.is_set(c).unwrap_or(false))
            .collect();
        Ok(Cpus(cpus))
    }

    /// The CPUs the calling thread may run on now.
    #[cfg(not(target_os = "linux"))]
    pub fn of_this_thread() -> Result<Self, AffinityError> {
        Err(AffinityError::Usage(
            "CPU affinity is supported on Linux only".to_owned(),
        ))
    }
}

impl fmt::Display for Cpus {
    /// The list format, ranges folded: `0-3,6`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut i = 0;
        let mut first = true;
        while i < self.0.len() {
            let start = self.0[i];
            let mut end = start;
            while i + 1 < self.0.len() && self.0[i + 1] == end + 1 {
                i += 1;
                end = self.0[i];
            }
            if !first {
                f.write_str(",")?;
            }
            first = false;
            if end == start {
                write!(f, "{start}")?;
            } else {
                write!(f, "{start}-{end}")?;
            }
            i += 1;
        }
        Ok(())
    }
}

/// The CPUs the calling thread may run on, in the list format, as the
/// summaries record them: empty where unknown.
pub fn current_list() -> String {
    Cpus::of_this_thread().map_or_else(|_| String::new(), |c| c.to_string())
}

/// A recorded list for people: `?` for the empty (unknown) one.
pub fn shown(list: &str) -> &str {
    if list.is_empty() { "?" } else { list }
}

/// Restricts every thread of this process to `cpus` (threads and child
/// processes started later inherit it). A set with a CPU this process may not
/// run on (offline, absent, outside its cgroup) is refused with a usage error
/// naming it, and nothing changes.
#[cfg(target_os = "linux")]
pub fn pin_process(cpus: &Cpus) -> Result<(), AffinityError> {
    use nix::errno::Errno;
    use nix::sched::{CpuSet, sched_setaffinity};
    use nix::unistd::Pid;
    let online = || {
        std::fs::read_to_string("/sys/devices/system/cpu/online")
            .ok()
            .and_then(|t| Cpus::parse(t.trim()).ok())
            .map_or_else(String::new, |c| format!(" (CPUs online: {c})"))
    };
    let mut set = CpuSet::new();
    for &c in cpus.list() {
        set.set(c)
            .map_err(|e| AffinityError::Usage(format!("--cpu {cpus}: CPU {c}: {e}")))?;
    }
    let set_thread = |tid: i32, set: &CpuSet| sched_setaffinity(Pid::from_raw(tid), set);
    // This thread first: the kernel refuses a set with no usable CPU (EINVAL)
    // and silently drops the unusable ones of another; both are refused here.
    let before = Cpus::of_this_thread()?;
    match set_thread(0, &set) {
        Ok(()) => {}
        Err(Errno::EINVAL) => {
            return Err(AffinityError::Usage(format!(
                "--cpu {cpus}: none of these CPUs is available to this process{}",
                online()
            )));
        }
        Err(e) => {
            return Err(AffinityError::System(format!(
                "cannot run on CPUs {cpus}: sched_setaffinity: {e}"
            )));
        }
    }
    let now = Cpus::of_this_thread()?;
    if let Some(c) = cpus.list().iter().find(|c| !now.list().contains(c)) {
        let mut back = CpuSet::new();
        for &b in before.list() {
            let _ = back.set(b);
        }
        let _ = set_thread(0, &back);
        return Err(AffinityError::Usage(format!(
            "--cpu {cpus}: CPU {c} is not available to this process{}",
            online()
        )));
    }
    let tasks = std::fs::read_dir("/proc/self/task")
        .map_err(|e| AffinityError::System(format!("cannot list this process's threads: {e}")))?;
    for task in tasks {
        let tid = task
            .ok()
            .and_then(|t| t.file_name().to_str().and_then(|s| s.parse::<i32>().ok()));
        let Some(tid) = tid else { continue };
        match set_thread(tid, &set) {
            // A thread that ended since the listing.
            Ok(()) | Err(Errno::ESRCH) => {}
            Err(e) => {
                return Err(AffinityError::System(format!(
                    "cannot run on CPUs {cpus}: sched_setaffinity: {e}"
                )));
            }
        }
    }
    Ok(())
}

/// Restricts every thread of this process to `cpus`: Linux only.
#[cfg(not(target_os = "linux"))]
pub fn pin_process(cpus: &Cpus) -> Result<(), AffinityError> {
    Err(AffinityError::Usage(format!(
        "--cpu {cpus}: CPU affinity is supported on Linux only"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_list_format_parses_and_prints_folded() {
        let c = Cpus::parse("3,0-1, 6 ,1").unwrap();
        assert_eq!(c.list(), &[0, 1, 3, 6]);
        assert_eq!(c.to_string(), "0-1,3,6");
        assert_eq!(Cpus::parse("2").unwrap().to_string(), "2");
        assert_eq!(Cpus::parse("0-3").unwrap().to_string(), "0-3");
    }

    #[test]
    fn bad_lists_are_usage_errors_that_say_what_is_wrong() {
        for (text, why) in [
            ("", "an empty item"),
            ("0,,1", "an empty item"),
            ("x", "\"x\" is not a CPU number"),
            ("-1", "\"\" is not a CPU number"),
            ("3-1", "runs backwards"),
            ("4096", "above 1023"),
        ] {
            let e = Cpus::parse(text).unwrap_err();
            assert!(e.is_usage(), "{text}: {e}");
            assert!(e.to_string().contains(why), "{text}: {e}");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn this_thread_may_run_somewhere() {
        assert!(!Cpus::of_this_thread().unwrap().list().is_empty());
    }
}
