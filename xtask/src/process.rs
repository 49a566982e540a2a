//! Small helpers around [`std::process::Command`]: echo, run, time out, capture.
//!
//! Every failure is turned into a message that names the command and its exit
//! status, so callers can pass it straight up with `?`.

use std::ffi::OsStr;
use std::path::PathBuf;
use std::process::{Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// Result type of the whole xtask: errors are human-readable messages.
pub type Result<T> = std::result::Result<T, String>;

/// Renders a command the way a user would type it (environment overrides first).
pub fn display(cmd: &Command) -> String {
    let mut parts: Vec<String> = Vec::new();
    for (key, value) in cmd.get_envs() {
        if let Some(value) = value {
            parts.push(format!(
                "{}={}",
                key.to_string_lossy(),
                value.to_string_lossy()
            ));
        }
    }
    parts.push(quote(cmd.get_program()));
    parts.extend(cmd.get_args().map(quote));
    let line = parts.join(" ");
    match cmd.get_current_dir() {
        Some(dir) => format!("(cd {} && {line})", dir.display()),
        None => line,
    }
}

fn quote(arg: &OsStr) -> String {
    let s = arg.to_string_lossy();
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_=+.,/:@%".contains(c))
    {
        s.into_owned()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

fn describe_status(status: ExitStatus) -> String {
    match status.code() {
        Some(code) => format!("exit status {code}"),
        None => format!("{status} (killed by a signal)"),
    }
}

fn check(cmd: &Command, status: ExitStatus) -> Result<()> {
    if status.success() {
        Ok(())
    } else {
        Err(format!(
            "command `{}` failed with {}",
            display(cmd),
            describe_status(status)
        ))
    }
}

fn spawn_error(cmd: &Command, err: &std::io::Error) -> String {
    format!("could not start `{}`: {err}", display(cmd))
}

/// Echoes `cmd`, runs it with inherited stdio and fails unless it exits with 0.
pub fn run(cmd: &mut Command) -> Result<()> {
    println!("$ {}", display(cmd));
    let status = cmd.status().map_err(|e| spawn_error(cmd, &e))?;
    check(cmd, status)
}

/// Like [`run`], but kills the command if it has not finished after `timeout`.
pub fn run_with_timeout(cmd: &mut Command, timeout: Duration) -> Result<()> {
    println!("$ {}   (time limit {} s)", display(cmd), timeout.as_secs());
    let mut child = cmd.spawn().map_err(|e| spawn_error(cmd, &e))?;
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return check(cmd, status),
            Ok(None) if start.elapsed() >= timeout => {
                // Either may fail if the child exited in the meantime; that is fine.
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "command `{}` did not finish within {} s and was killed",
                    display(cmd),
                    timeout.as_secs()
                ));
            }
            Ok(None) => thread::sleep(Duration::from_millis(100)),
            Err(e) => return Err(format!("waiting for `{}` failed: {e}", display(cmd))),
        }
    }
}

/// Runs `cmd` quietly and returns its stdout if it exits with 0.
///
/// Stderr is captured too and included in the error message on failure.
pub fn output(cmd: &mut Command) -> Result<String> {
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .map_err(|e| spawn_error(cmd, &e))?;
    if out.status.success() {
        Ok(String::from_utf8_lossy(&out.stdout).into_owned())
    } else {
        let stderr = String::from_utf8_lossy(&out.stderr);
        Err(format!(
            "command `{}` failed with {}: {}",
            display(cmd),
            describe_status(out.status),
            stderr.trim()
        ))
    }
}

/// Like [`output`], but kills the command if it has not finished after `timeout`.
///
/// For commands that print little: the output is read after the command exits, so
/// one that fills a pipe (64 KiB) stalls until the time limit.
pub fn output_with_timeout(cmd: &mut Command, timeout: Duration) -> Result<String> {
    println!("$ {}   (time limit {} s)", display(cmd), timeout.as_secs());
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| spawn_error(cmd, &e))?;
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if start.elapsed() >= timeout => {
                // Either may fail if the child exited in the meantime; that is fine.
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "command `{}` did not finish within {} s and was killed",
                    display(cmd),
                    timeout.as_secs()
                ));
            }
            Ok(None) => thread::sleep(Duration::from_millis(100)),
            Err(e) => return Err(format!("waiting for `{}` failed: {e}", display(cmd))),
        }
    }
    // The child has exited: its pipes are at their ends and cannot block.
    let out = child
        .wait_with_output()
        .map_err(|e| format!("reading the output of `{}`: {e}", display(cmd)))?;
    if out.status.success() {
        Ok(String::from_utf8_lossy(&out.stdout).into_owned())
    } else {
        Err(format!(
            "command `{}` failed with {}: {}",
            display(cmd),
            describe_status(out.status),
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Runs `cmd` quietly and reports only whether it exited with 0.
pub fn succeeds(cmd: &mut Command) -> bool {
    cmd.stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Finds an executable called `name` on `PATH`.
pub fn which(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|candidate| is_executable(candidate))
}

#[cfg(unix)]
fn is_executable(path: &std::path::Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    path.metadata()
        .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

#[cfg(not(unix))]
fn is_executable(path: &std::path::Path) -> bool {
    path.is_file()
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn display_quotes_only_when_needed() {
        let mut cmd = Command::new("cargo");
        cmd.args(["build", "-Z", "build-std=core", "a b", "it's"])
            .env("RUSTC_BOOTSTRAP", "1");
        assert_eq!(
            display(&cmd),
            r"RUSTC_BOOTSTRAP=1 cargo build -Z build-std=core 'a b' 'it'\''s'"
        );
    }

    #[test]
    fn failure_names_command_and_status() {
        let err = run(Command::new("sh").args(["-c", "exit 3"])).unwrap_err();
        assert!(err.contains("`sh -c 'exit 3'`"), "{err}");
        assert!(err.contains("exit status 3"), "{err}");
    }

    #[test]
    fn missing_program_is_reported() {
        let err = run(&mut Command::new("xtask-no-such-program")).unwrap_err();
        assert!(
            err.starts_with("could not start `xtask-no-such-program`"),
            "{err}"
        );
    }

    #[test]
    fn timeout_kills_the_command() {
        let start = Instant::now();
        let err = run_with_timeout(Command::new("sleep").arg("30"), Duration::from_millis(300))
            .unwrap_err();
        assert!(err.contains("was killed"), "{err}");
        assert!(start.elapsed() < Duration::from_secs(10));
    }

    #[test]
    fn output_and_which() {
        assert_eq!(output(Command::new("echo").arg("hi")).unwrap(), "hi\n");
        assert!(which("sh").is_some());
        assert!(which("xtask-no-such-program").is_none());
    }
}
