//! `apt-get` for `cargo xtask setup`, which never removes a package.
//!
//! Every install is simulated first (`apt-get install -s`): one that would remove
//! a package is not run, and the packages it would remove come back to the
//! caller ([`InstallError::WouldRemove`]) to find another way or to stop with
//! them named; the real install passes `--no-remove` as well, so that apt itself
//! refuses a removal the simulation did not show. `--no-install-recommends`
//! always.
//!
//! A Debian suite the machine's sources lack (`bookworm-backports`, say) is
//! reached through [`Sources`]: a temporary directory given to apt as
//! `Dir::Etc::sourceparts`, holding copies of the machine's own source files plus
//! one file for that suite. The machine's own sources must be in it, because
//! `apt-get update` drops the package lists of every source it is not given.
//! Nothing under `/etc/apt` is changed.

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::process::{self, Result};

/// The Debian archive that a [`Sources`] suite is fetched from.
pub const DEBIAN_ARCHIVE: &str = "http://deb.debian.org/debian";
/// The keyring that signs [`DEBIAN_ARCHIVE`] (package `debian-archive-keyring`).
pub const DEBIAN_KEYRING: &str = "/usr/share/keyrings/debian-archive-keyring.gpg";

/// A package that an install would remove, and its installed version.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Removal {
    /// The package.
    pub package: String,
    /// Its installed version (empty if apt did not say).
    pub version: String,
}

impl fmt::Display for Removal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.version.is_empty() {
            f.write_str(&self.package)
        } else {
            write!(f, "{} {}", self.package, self.version)
        }
    }
}

/// The packages in `removals`, for messages: `a 1.0, b 2.0`.
pub fn list(removals: &[Removal]) -> String {
    removals
        .iter()
        .map(Removal::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// What an `apt-get install -s` would do.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    /// Packages it would install or upgrade, with the version (`Inst` lines).
    pub installs: Vec<(String, String)>,
    /// Packages it would remove (`Remv` lines).
    pub removals: Vec<Removal>,
}

impl Plan {
    /// The version the plan installs of `package`, if it installs it.
    pub fn version_of(&self, package: &str) -> Option<&str> {
        self.installs
            .iter()
            .find(|(name, _)| name == package)
            .map(|(_, version)| version.as_str())
    }
}

/// Why an install was not done.
#[derive(Debug)]
pub enum InstallError {
    /// It would remove packages that the machine has; it was not run.
    WouldRemove {
        /// What the simulation planned (the removals among it).
        plan: Plan,
    },
    /// apt-get could not plan it or failed running it (the message names the
    /// command and its output).
    Failed(String),
}

impl fmt::Display for InstallError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InstallError::WouldRemove { plan } => write!(
                f,
                "it would remove {}, which this machine has (setup removes nothing)",
                list(&plan.removals)
            ),
            InstallError::Failed(message) => f.write_str(message),
        }
    }
}

/// A version of a package that the configured sources offer, and its suite.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Candidate {
    /// The Debian version (`1:7.2+dfsg-7+deb12u18+b3`).
    pub version: String,
    /// The suite that carries it (`bookworm`, `bookworm-backports`).
    pub suite: String,
}

/// The machine's apt source files plus one Debian suite, in a temporary
/// directory that apt reads as `Dir::Etc::sourceparts` (removed on drop).
pub struct Sources {
    dir: PathBuf,
    suite: String,
}

impl Sources {
    /// Copies the machine's source files (`*.list`, `*.sources` in apt's
    /// `Dir::Etc::sourceparts`) and adds [`DEBIAN_ARCHIVE`]'s `suite` (component
    /// `main`, signed by [`DEBIAN_KEYRING`]).
    pub fn with_debian_suite(suite: &str) -> Result<Self> {
        if !Path::new(DEBIAN_KEYRING).is_file() {
            return Err(format!(
                "{DEBIAN_KEYRING} is missing (package debian-archive-keyring): cannot add {suite}"
            ));
        }
        let parts = machine_sourceparts()?;
        let dir = std::env::temp_dir().join(format!("xtask-apt-{}-{suite}", std::process::id()));
        Self::create(&parts, suite, dir)
    }

    /// [`Sources::with_debian_suite`] from the source files in `parts`, in `dir`.
    fn create(parts: &Path, suite: &str, dir: PathBuf) -> Result<Self> {
        let io =
            |what: &str, path: &Path, e: std::io::Error| format!("{what} {}: {e}", path.display());
        if dir.exists() {
            fs::remove_dir_all(&dir).map_err(|e| io("cannot remove", &dir, e))?;
        }
        fs::create_dir_all(&dir).map_err(|e| io("cannot create", &dir, e))?;
        let sources = Sources {
            dir,
            suite: suite.to_owned(),
        };
        // A missing directory is a machine with only /etc/apt/sources.list.
        if let Ok(entries) = fs::read_dir(parts) {
            for entry in entries.filter_map(|entry| entry.ok()) {
                let path = entry.path();
                let is_source = path
                    .extension()
                    .is_some_and(|ext| ext == "list" || ext == "sources");
                if is_source && path.is_file() {
                    let copy = sources.dir.join(entry.file_name());
                    fs::copy(&path, &copy).map_err(|e| io("cannot copy", &path, e))?;
                }
            }
        }
        let file = sources.dir.join(format!("xtask-{suite}.sources"));
        fs::write(
            &file,
            format!(
                "Types: deb\nURIs: {DEBIAN_ARCHIVE}\nSuites: {suite}\nComponents: main\n\
                 Signed-By: {DEBIAN_KEYRING}\n"
            ),
        )
        .map_err(|e| io("cannot write", &file, e))?;
        Ok(sources)
    }

    /// The suite added to the machine's sources.
    pub fn suite(&self) -> &str {
        &self.suite
    }

    /// apt's option that reads these sources instead of the machine's directory.
    fn options(&self) -> [String; 2] {
        [
            "-o".to_owned(),
            format!("Dir::Etc::sourceparts={}", self.dir.display()),
        ]
    }
}

impl Drop for Sources {
    fn drop(&mut self) {
        // A temporary directory left behind is harmless.
        let _ = fs::remove_dir_all(&self.dir);
    }
}

/// The machine's `Dir::Etc::sourceparts` (`/etc/apt/sources.list.d/`), from
/// `apt-config`.
fn machine_sourceparts() -> Result<PathBuf> {
    let out = process::output(Command::new("apt-config").args([
        "shell",
        "PARTS",
        "Dir::Etc::sourceparts/d",
    ]))?;
    out.lines()
        .find_map(|line| line.strip_prefix("PARTS="))
        .map(|value| PathBuf::from(value.trim().trim_matches('\'')))
        .ok_or_else(|| {
            format!(
                "apt-config did not name Dir::Etc::sourceparts: `{}`",
                out.trim()
            )
        })
}

/// Runs `apt-get`, with `sudo` when not root, updating the machine's index at
/// most once; installs only what removes nothing.
#[derive(Default)]
pub struct Apt {
    updated: bool,
}

impl Apt {
    /// `apt-get` as root (directly, or through `sudo`) with `sources` and `args`.
    fn privileged(sources: Option<&Sources>, args: &[&str]) -> Result<Command> {
        let manual = format!("apt-get {}", args.join(" "));
        if process::which("apt-get").is_none() {
            return Err(format!(
                "apt-get not found; install by hand the equivalent of: {manual}"
            ));
        }
        let mut cmd = if is_root() {
            Command::new("apt-get")
        } else if process::which("sudo").is_some() {
            let mut cmd = Command::new("sudo");
            cmd.args(["DEBIAN_FRONTEND=noninteractive", "apt-get"]);
            cmd
        } else {
            return Err(format!(
                "not root and sudo is not available; as root run: {manual}"
            ));
        };
        cmd.env("DEBIAN_FRONTEND", "noninteractive")
            .args(["-o", "DPkg::Lock::Timeout=300"]);
        if let Some(sources) = sources {
            cmd.args(sources.options());
        }
        cmd.args(args);
        Ok(cmd)
    }

    /// A read-only apt program (`apt-get -s`, `apt-get download`, `apt-cache`),
    /// which needs no root, with `sources` and `args`, in the C locale (its
    /// output is parsed).
    fn reader(program: &str, sources: Option<&Sources>, args: &[&str]) -> Command {
        let mut cmd = Command::new(program);
        cmd.env("LC_ALL", "C");
        if let Some(sources) = sources {
            cmd.args(sources.options());
        }
        cmd.args(args);
        cmd
    }

    /// `apt-get update` of the machine's sources, once per run. A partly failing
    /// update (one unreachable mirror) does not stop setup: the install says
    /// clearly if a package is unavailable.
    pub fn update(&mut self) -> Result<()> {
        if !self.updated {
            self.updated = true;
            if let Err(e) = process::run(&mut Self::privileged(None, &["update"])?) {
                println!("warning: {e}; trying the install anyway");
            }
        }
        Ok(())
    }

    /// `apt-get update` with `sources` (the machine's and one more suite).
    pub fn update_with(&mut self, sources: &Sources) -> Result<()> {
        process::run(&mut Self::privileged(Some(sources), &["update"])?)
            .map_err(|e| format!("cannot read the package lists of {}: {e}", sources.suite()))?;
        // The machine's own sources were updated too.
        self.updated = true;
        Ok(())
    }

    /// What `apt-get install` of `packages` would do (`-s`, nothing changed),
    /// preferring `release` (`-t`) if given.
    pub fn simulate(
        sources: Option<&Sources>,
        release: Option<&str>,
        packages: &[&str],
    ) -> std::result::Result<Plan, InstallError> {
        let mut args = vec!["install", "-s", "--no-install-recommends"];
        if let Some(release) = release {
            args.extend(["-t", release]);
        }
        args.extend_from_slice(packages);
        let out = process::output(&mut Self::reader("apt-get", sources, &args))
            .map_err(InstallError::Failed)?;
        Ok(parse_simulation(&out))
    }

    /// Installs `packages` (`--no-install-recommends`, preferring `release` if
    /// given) if that removes nothing: simulated first, then run with
    /// `--no-remove`. Updates the machine's index first (once) when `sources`
    /// is `None`; with `sources`, [`Apt::update_with`] must have run.
    pub fn install(
        &mut self,
        sources: Option<&Sources>,
        release: Option<&str>,
        packages: &[&str],
    ) -> std::result::Result<Plan, InstallError> {
        if sources.is_none() {
            self.update().map_err(InstallError::Failed)?;
        }
        let plan = Self::simulate(sources, release, packages)?;
        if !plan.removals.is_empty() {
            return Err(InstallError::WouldRemove { plan });
        }
        let mut args = vec!["install", "-y", "--no-install-recommends", "--no-remove"];
        if let Some(release) = release {
            args.extend(["-t", release]);
        }
        args.extend_from_slice(packages);
        let mut cmd = Self::privileged(sources, &args).map_err(InstallError::Failed)?;
        process::run(&mut cmd).map_err(InstallError::Failed)?;
        Ok(plan)
    }

    /// The versions of `package` that the sources offer (`apt-cache madison`),
    /// each with its suite.
    pub fn candidates(sources: Option<&Sources>, package: &str) -> Result<Vec<Candidate>> {
        let out = process::output(&mut Self::reader(
            "apt-cache",
            sources,
            &["madison", package],
        ))?;
        Ok(parse_madison(&out))
    }

    /// Downloads the `.deb` of `package` at `version` into `dir` (`apt-get
    /// download`; nothing is installed) and returns its path.
    pub fn download(
        sources: Option<&Sources>,
        package: &str,
        version: &str,
        dir: &Path,
    ) -> Result<PathBuf> {
        if dir.exists() {
            fs::remove_dir_all(dir).map_err(|e| format!("cannot remove {}: {e}", dir.display()))?;
        }
        fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let wanted = format!("{package}={version}");
        let mut cmd = Self::reader("apt-get", sources, &[]);
        if is_root() {
            // apt's sandbox user cannot write to a directory of root's; as root
            // it downloads unsandboxed anyway, and says so in a warning.
            cmd.args(["-o", "APT::Sandbox::User=root"]);
        }
        cmd.args(["download", &wanted]).current_dir(dir);
        process::run(&mut cmd)?;
        let debs: Vec<PathBuf> = fs::read_dir(dir)
            .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
            .filter_map(|entry| entry.ok().map(|entry| entry.path()))
            .filter(|path| path.extension().is_some_and(|ext| ext == "deb"))
            .collect();
        match debs.as_slice() {
            [deb] => Ok(deb.clone()),
            other => Err(format!(
                "`apt-get download {wanted}` left {} .deb files in {}, expected one",
                other.len(),
                dir.display()
            )),
        }
    }
}

/// Whether this process runs as root.
pub fn is_root() -> bool {
    process::output(Command::new("id").arg("-u")).is_ok_and(|uid| uid.trim() == "0")
}

/// Whether dpkg says `package` is installed.
pub fn installed(package: &str) -> bool {
    process::output(Command::new("dpkg-query").args(["-W", "-f=${Status}", package]))
        .is_ok_and(|status| status.trim_end().ends_with("install ok installed"))
}

/// Whether Debian version `a` is greater than `b` (`dpkg --compare-versions`).
pub fn newer(a: &str, b: &str) -> bool {
    process::succeeds(Command::new("dpkg").args(["--compare-versions", a, "gt", b]))
}

/// The `Inst` and `Remv` lines of `apt-get install -s` output:
/// `Inst qemu-system-arm [old] (1:7.2+dfsg-7+deb12u18+b3 Debian:12.11/stable [amd64])`
/// and `Remv qemu-utils [1:10.0.2+ds-2+deb13u1~bpo12+1]`.
pub fn parse_simulation(output: &str) -> Plan {
    let mut plan = Plan::default();
    for line in output.lines() {
        let mut words = line.split_whitespace();
        let (Some(kind), Some(package)) = (words.next(), words.next()) else {
            continue;
        };
        let rest: Vec<&str> = words.collect();
        match kind {
            "Inst" => {
                let version = rest
                    .iter()
                    .find_map(|word| word.strip_prefix('('))
                    .unwrap_or_default();
                plan.installs.push((package.to_owned(), version.to_owned()));
            }
            "Remv" => {
                let version = rest
                    .first()
                    .and_then(|word| word.strip_prefix('['))
                    .and_then(|word| word.strip_suffix(']'))
                    .unwrap_or_default();
                plan.removals.push(Removal {
                    package: package.to_owned(),
                    version: version.to_owned(),
                });
            }
            _ => {}
        }
    }
    plan
}

/// The binary-package lines of `apt-cache madison` output:
/// `qemu-system-arm | 1:7.2+dfsg-7+deb12u18+b3 | http://deb.debian.org/debian bookworm/main amd64 Packages`.
pub fn parse_madison(output: &str) -> Vec<Candidate> {
    output
        .lines()
        .filter_map(|line| {
            let mut fields = line.split('|').map(str::trim);
            let (_package, version, source) = (fields.next()?, fields.next()?, fields.next()?);
            let words: Vec<&str> = source.split_whitespace().collect();
            if words.last() != Some(&"Packages") {
                return None;
            }
            let suite = words.get(1)?.split('/').next()?;
            Some(Candidate {
                version: version.to_owned(),
                suite: suite.to_owned(),
            })
        })
        .collect()
}

/// The upstream major version of a Debian version: `7` for
/// `1:7.2+dfsg-7+deb12u18+b3`, `10` for `1:10.0.2+ds-2+deb13u1~bpo12+1`.
pub fn upstream_major(version: &str) -> Option<u32> {
    let upstream = version.split_once(':').map_or(version, |(_, rest)| rest);
    let digits: String = upstream.chars().take_while(char::is_ascii_digit).collect();
    digits.parse().ok()
}

/// The machine's release from `/etc/os-release` text: (`ID`, `VERSION_ID`,
/// `VERSION_CODENAME`).
fn os_release_fields(os_release: &str) -> (Option<&str>, Option<&str>, Option<&str>) {
    let field = |key: &str| {
        os_release.lines().find_map(|line| {
            line.strip_prefix(key)?
                .strip_prefix('=')
                .map(|value| value.trim().trim_matches('"'))
        })
    };
    (field("ID"), field("VERSION_ID"), field("VERSION_CODENAME"))
}

/// The backports suite of this Debian release (`bookworm-backports`), from
/// `/etc/os-release` text; `None` on other systems.
pub fn backports_suite(os_release: &str) -> Option<String> {
    match os_release_fields(os_release) {
        (Some("debian"), _, Some(codename)) if !codename.is_empty() => {
            Some(format!("{codename}-backports"))
        }
        _ => None,
    }
}

/// The suite that carries a backport `version` (`~bpo12` is bookworm's: its
/// `bookworm-backports`) if it is one of this release's (`/etc/os-release`
/// text), else `None`.
pub fn backports_suite_of(version: &str, os_release: &str) -> Option<String> {
    let release = version
        .split("~bpo")
        .nth(1)?
        .split(|c: char| !c.is_ascii_digit())
        .next()?;
    match os_release_fields(os_release) {
        (_, Some(version_id), _) if version_id == release => backports_suite(os_release),
        _ => None,
    }
}

/// This machine's `/etc/os-release` (empty if unreadable).
pub fn os_release() -> String {
    fs::read_to_string("/etc/os-release").unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOOKWORM: &str = "PRETTY_NAME=\"Debian GNU/Linux 12 (bookworm)\"\nNAME=\"Debian GNU/Linux\"\n\
                            VERSION_ID=\"12\"\nVERSION=\"12 (bookworm)\"\nVERSION_CODENAME=bookworm\nID=debian\n";

    #[test]
    fn a_simulation_names_what_it_installs_and_removes() {
        // What `apt-get install -s --no-install-recommends qemu-system-arm` printed
        // on a bookworm machine with the backports' qemu-utils 10.0.2 (abridged).
        let out = "NOTE: This is only a simulation!\n\
                   The following packages will be REMOVED:\n  qemu-utils\n\
                   Remv qemu-utils [1:10.0.2+ds-2+deb13u1~bpo12+1]\n\
                   Inst libepoxy0 (1.5.10-1 Debian:12.15/oldstable [amd64])\n\
                   Inst qemu-system-arm [1:10.0.2+ds-2+deb13u1~bpo12+1] (1:7.2+dfsg-7+deb12u18+b3 Debian:12.15/oldstable [amd64]) []\n\
                   Conf qemu-system-arm (1:7.2+dfsg-7+deb12u18+b3 Debian:12.15/oldstable [amd64])\n";
        let plan = parse_simulation(out);
        assert_eq!(
            plan.removals,
            [Removal {
                package: "qemu-utils".into(),
                version: "1:10.0.2+ds-2+deb13u1~bpo12+1".into()
            }]
        );
        assert_eq!(
            plan.version_of("qemu-system-arm"),
            Some("1:7.2+dfsg-7+deb12u18+b3")
        );
        assert_eq!(plan.version_of("libepoxy0"), Some("1.5.10-1"));
        assert_eq!(plan.version_of("qemu-utils"), None);
        assert_eq!(
            list(&plan.removals),
            "qemu-utils 1:10.0.2+ds-2+deb13u1~bpo12+1"
        );
        let clean = parse_simulation("qemu-system-arm is already the newest version.\n");
        assert!(clean.removals.is_empty() && clean.installs.is_empty());
    }

    #[test]
    fn madison_lines_give_versions_and_suites() {
        let out = "qemu-system-arm | 1:10.0.2+ds-2+deb13u1~bpo12+1 | http://deb.debian.org/debian bookworm-backports/main amd64 Packages\n\
                   qemu-system-arm | 1:7.2+dfsg-7+deb12u18+b3 | http://deb.debian.org/debian bookworm/main amd64 Packages\n\
                   qemu-system-arm | 1:7.2+dfsg-7+deb12u15 | http://deb.debian.org/debian-security bookworm-security/main amd64 Packages\n\
                   qemu | 1:7.2+dfsg-7+deb12u18 | http://deb.debian.org/debian bookworm/main Sources\n";
        let candidates = parse_madison(out);
        let pairs: Vec<(&str, &str)> = candidates
            .iter()
            .map(|c| (c.version.as_str(), c.suite.as_str()))
            .collect();
        assert_eq!(
            pairs,
            [
                ("1:10.0.2+ds-2+deb13u1~bpo12+1", "bookworm-backports"),
                ("1:7.2+dfsg-7+deb12u18+b3", "bookworm"),
                ("1:7.2+dfsg-7+deb12u15", "bookworm-security"),
            ]
        );
    }

    #[test]
    fn versions_and_suites() {
        assert_eq!(upstream_major("1:7.2+dfsg-7+deb12u18+b3"), Some(7));
        assert_eq!(upstream_major("1:10.0.2+ds-2+deb13u1~bpo12+1"), Some(10));
        assert_eq!(upstream_major("9.1.0"), Some(9));
        assert_eq!(upstream_major("1:x"), None);
        assert_eq!(
            backports_suite(BOOKWORM).as_deref(),
            Some("bookworm-backports")
        );
        assert_eq!(
            backports_suite_of("1:10.0.2+ds-2+deb13u1~bpo12+1", BOOKWORM).as_deref(),
            Some("bookworm-backports")
        );
        // Another release's backport, or none at all.
        assert_eq!(backports_suite_of("1:9.2+ds-1~bpo11+1", BOOKWORM), None);
        assert_eq!(
            backports_suite_of("1:7.2+dfsg-7+deb12u18+b3", BOOKWORM),
            None
        );
        assert_eq!(
            backports_suite("ID=ubuntu\nVERSION_ID=\"24.04\"\nVERSION_CODENAME=noble\n"),
            None
        );
    }

    #[test]
    fn sources_keep_the_machines_and_add_the_suite() {
        let base = std::env::temp_dir().join(format!("xtask-apt-test-{}", std::process::id()));
        let parts = base.join("sources.list.d");
        fs::create_dir_all(&parts).unwrap();
        fs::write(
            parts.join("debian.sources"),
            "Types: deb\nSuites: bookworm\n",
        )
        .unwrap();
        fs::write(
            parts.join("old.list"),
            "deb http://example.invalid x main\n",
        )
        .unwrap();
        fs::write(
            parts.join("off.list.disabled"),
            "deb http://example.invalid y main\n",
        )
        .unwrap();
        let dir = base.join("tmp");
        let sources = Sources::create(&parts, "bookworm-backports", dir.clone()).unwrap();
        let mut names: Vec<String> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(
            names,
            [
                "debian.sources",
                "old.list",
                "xtask-bookworm-backports.sources"
            ]
        );
        let added = fs::read_to_string(dir.join("xtask-bookworm-backports.sources")).unwrap();
        assert!(added.contains("Suites: bookworm-backports\n"), "{added}");
        assert!(
            added.contains(&format!("Signed-By: {DEBIAN_KEYRING}\n")),
            "{added}"
        );
        assert_eq!(
            sources.options()[1],
            format!("Dir::Etc::sourceparts={}", dir.display())
        );
        drop(sources);
        assert!(!dir.exists(), "the temporary sources are removed");
        fs::remove_dir_all(&base).unwrap();
    }
}
