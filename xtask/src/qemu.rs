//! QEMU for the firmware: the system's `qemu-system-arm`, installed without
//! removing any package, and a second QEMU version for comparison, unpacked
//! privately under `target/qemu/` and never installed system-wide.
//!
//! The system's QEMU. When `qemu-system-arm` is missing, Debian's candidate is
//! installed if that removes nothing. It can remove something: a machine with
//! QEMU packages from `bookworm-backports` (qemu-utils 10.0, which breaks
//! qemu-system-common before 8.0) would lose them to bookworm's QEMU 7.2. Then the
//! qemu-system-arm of the installed QEMU packages' version is installed from the
//! suite that carries it: from the machine's own sources, or from this release's
//! backports through a temporary source list ([`apt::Sources`]). If no way
//! installs without removing, setup stops and names what would be removed.
//!
//! The comparison copy. The HIL tests fly the same frames under both versions
//! and require identical answers, instruction counts included. The version is
//! the other major version Debian offers this machine: bookworm's 7.2 when the
//! system's is the backports' 10, the backports' 10 when the system's is 7.2. It
//! is fetched with `apt-get download` and unpacked with `dpkg-deb -x` into
//! `target/qemu/<Debian version without epoch>/`; its binary,
//! `usr/bin/qemu-system-arm`, runs with the system's libraries (with `-kernel` on
//! the Arm boards it needs no data files). When it cannot be provided, setup says
//! why and writes the reason to `target/qemu/unavailable.txt`, which the test
//! shows as it skips. decoy-hil reads this layout (`decoy_hil::qemu::COMPARISON_DIR`).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::apt::{self, Apt, Candidate, InstallError, Plan, Sources};
use crate::process::{self, Result};

/// The Debian package of QEMU for the Arm boards.
pub const PACKAGE: &str = "qemu-system-arm";
/// The binary it provides.
pub const BINARY: &str = "qemu-system-arm";

/// Where the comparison copies are unpacked, relative to the workspace root
/// (the same as `decoy_hil::qemu::COMPARISON_DIR`).
const COMPARISON_DIR: &str = "target/qemu";
/// The binary within one copy (`decoy_hil::qemu::COMPARISON_BINARY`).
const COMPARISON_BINARY: &str = "usr/bin/qemu-system-arm";
/// Why no copy could be provided (`decoy_hil::qemu::COMPARISON_UNAVAILABLE`).
const COMPARISON_UNAVAILABLE: &str = "unavailable.txt";
/// The download directory within [`COMPARISON_DIR`].
const DOWNLOAD_DIR: &str = "download";

/// What setup found or did.
pub struct Outcome {
    /// Whether setup installed or unpacked it (else it was there).
    pub installed: bool,
    /// What it is, for the summary lists (`qemu-system-arm 10.0.2`).
    pub item: String,
    /// The line that says so.
    pub detail: String,
}

/// A QEMU binary and its version number (`10.0.2`).
pub struct Binary {
    /// The binary (a name on `PATH` for the system's).
    pub program: PathBuf,
    /// The version number from `--version`.
    pub version: String,
    /// The first line of `--version`.
    pub line: String,
}

impl Binary {
    /// Runs `program --version` and reads "QEMU emulator version X.Y.Z ...".
    fn probe(program: &Path) -> Result<Binary> {
        let out = process::output(Command::new(program).arg("--version"))?;
        let line = out.lines().next().unwrap_or_default().trim().to_owned();
        let version = line
            .strip_prefix("QEMU emulator version ")
            .and_then(|rest| rest.split_whitespace().next())
            .filter(|v| v.starts_with(|c: char| c.is_ascii_digit()))
            .ok_or_else(|| {
                format!(
                    "`{} --version` printed `{line}`, not \"QEMU emulator version X.Y.Z\"",
                    program.display()
                )
            })?
            .to_owned();
        Ok(Binary {
            program: program.to_owned(),
            version,
            line,
        })
    }

    /// The major version (`10`).
    fn major(&self) -> Option<u32> {
        apt::upstream_major(&self.version)
    }
}

/// Makes sure `qemu-system-arm` runs, installing it without removing anything
/// when it is missing; returns it and what was done.
pub fn system(apt: &mut Apt) -> Result<(Binary, Outcome)> {
    if process::which(BINARY).is_some() {
        let binary = Binary::probe(Path::new(BINARY))?;
        let outcome = Outcome {
            installed: false,
            item: format!("{PACKAGE} {}", binary.version),
            detail: format!("{BINARY} ({})", binary.line),
        };
        return Ok((binary, outcome));
    }
    println!("missing: {BINARY}; installing Debian package {PACKAGE} (nothing may be removed)");
    let how = install(&mut MachineApt { apt, added: None })?;
    let binary = Binary::probe(Path::new(BINARY))
        .map_err(|e| format!("{PACKAGE} was installed but does not run: {e}"))?;
    let outcome = Outcome {
        installed: true,
        item: format!("{PACKAGE} {} ({how})", binary.version),
        detail: format!("{BINARY} ({}; {how})", binary.line),
    };
    Ok((binary, outcome))
}

/// The package operations [`install`] needs: apt on this machine
/// ([`MachineApt`]), or a script in the tests.
trait Packages {
    /// Installs `packages` if that removes nothing ([`Apt::install`]), through
    /// the added suite's sources once [`Packages::add_suite`] has run.
    fn install(
        &mut self,
        release: Option<&str>,
        packages: &[&str],
    ) -> std::result::Result<Plan, InstallError>;
    /// The versions of `package` on offer, and their suites.
    fn candidates(&mut self, package: &str) -> Result<Vec<Candidate>>;
    /// Adds Debian `suite` to the machine's sources for the calls that follow
    /// (a temporary source list) and reads its package lists.
    fn add_suite(&mut self, suite: &str) -> Result<()>;
    /// `/etc/os-release`.
    fn os_release(&self) -> String;
}

/// apt on this machine, with at most one added suite.
struct MachineApt<'a> {
    apt: &'a mut Apt,
    added: Option<Sources>,
}

impl Packages for MachineApt<'_> {
    fn install(
        &mut self,
        release: Option<&str>,
        packages: &[&str],
    ) -> std::result::Result<Plan, InstallError> {
        self.apt.install(self.added.as_ref(), release, packages)
    }

    fn candidates(&mut self, package: &str) -> Result<Vec<Candidate>> {
        Apt::candidates(self.added.as_ref(), package)
    }

    fn add_suite(&mut self, suite: &str) -> Result<()> {
        let sources = Sources::with_debian_suite(suite)?;
        self.apt.update_with(&sources)?;
        self.added = Some(sources);
        Ok(())
    }

    fn os_release(&self) -> String {
        apt::os_release()
    }
}

/// Installs qemu-system-arm: Debian's candidate if that removes nothing, else
/// the version of the installed QEMU packages from the suite that carries it.
/// Returns where it came from, for the summary.
fn install(packages: &mut impl Packages) -> Result<String> {
    let first = match packages.install(None, &[PACKAGE]) {
        Ok(plan) => {
            let version = plan.version_of(PACKAGE).unwrap_or("(its candidate)");
            println!("installed {PACKAGE} {version}, Debian's candidate: it removed nothing");
            return Ok("apt, Debian's candidate".into());
        }
        Err(InstallError::WouldRemove { plan }) => plan,
        Err(InstallError::Failed(e)) => return Err(format!("cannot install {PACKAGE}: {e}")),
    };
    let candidate = first.version_of(PACKAGE).unwrap_or("(its candidate)");
    println!(
        "not installed: Debian's candidate {PACKAGE} {candidate} would remove {}, which this \
         machine has",
        apt::list(&first.removals)
    );
    let refuse = |why: String| {
        format!(
            "cannot install {PACKAGE} without removing packages: Debian's candidate \
             {candidate} would remove {}; {why}. Setup removes nothing: install a \
             {PACKAGE} that fits the installed QEMU packages by hand, then run setup again",
            apt::list(&first.removals)
        )
    };
    let version = matching_version(&first.removals).map_err(refuse)?;
    println!("looking for {PACKAGE} {version}, the version of the installed QEMU packages");

    // From the machine's own sources if one of them carries the version, else
    // from this release's backports.
    let own = packages.candidates(PACKAGE).map_err(refuse)?;
    let suite = match own.iter().find(|c| c.version == version) {
        Some(found) => found.suite.clone(),
        None => {
            let suite =
                apt::backports_suite_of(&version, &packages.os_release()).ok_or_else(|| {
                    refuse(format!(
                        "{version} is in none of this machine's apt sources, and it is not a \
                     backport of this release"
                    ))
                })?;
            println!(
                "{version} comes from {suite}, which this machine's sources lack: reading it \
                 through a temporary source list (the machine's sources kept, /etc/apt unchanged)"
            );
            packages.add_suite(&suite).map_err(refuse)?;
            let offered = packages.candidates(PACKAGE).map_err(refuse)?;
            if !offered.iter().any(|c| c.version == version) {
                return Err(refuse(format!(
                    "{suite} does not offer {PACKAGE} {version}"
                )));
            }
            suite
        }
    };
    let wanted = format!("{PACKAGE}={version}");
    match packages.install(Some(&suite), &[&wanted]) {
        Ok(_) => {
            println!("installed {PACKAGE} {version} from {suite}: it removed nothing");
            Ok(format!(
                "apt, {suite}, matching the installed QEMU packages"
            ))
        }
        Err(InstallError::WouldRemove { plan }) => Err(refuse(format!(
            "{version} from {suite} would remove {}",
            apt::list(&plan.removals)
        ))),
        Err(InstallError::Failed(e)) => Err(refuse(format!("{version} from {suite}: {e}"))),
    }
}

/// The version of the QEMU packages that an install would remove (all the same).
fn matching_version(removals: &[apt::Removal]) -> std::result::Result<String, String> {
    let mut versions: Vec<&str> = removals
        .iter()
        .filter(|r| r.package.starts_with("qemu") && !r.version.is_empty())
        .map(|r| r.version.as_str())
        .collect();
    versions.sort_unstable();
    versions.dedup();
    match versions.as_slice() {
        [version] => Ok((*version).to_owned()),
        [] => Err("none of them is a QEMU package whose version could be matched".into()),
        several => Err(format!(
            "the installed QEMU packages are at several versions ({})",
            several.join(", ")
        )),
    }
}

/// Makes sure a QEMU of another major version than `system`'s is unpacked under
/// `root`'s `target/qemu/`, fetching it when it is not; on failure records why
/// in `target/qemu/unavailable.txt` (and returns the reason).
pub fn comparison(root: &Path, system: &Binary, apt: &mut Apt) -> Result<Outcome> {
    let dir = root.join(COMPARISON_DIR);
    let unavailable = dir.join(COMPARISON_UNAVAILABLE);
    let result = comparison_copy(root, &dir, system, apt);
    match &result {
        Ok(_) => {
            // No reason left behind for a copy that is there.
            let _ = fs::remove_file(&unavailable);
        }
        Err(reason) => {
            let written = fs::create_dir_all(&dir)
                .and_then(|()| fs::write(&unavailable, format!("{reason}\n")));
            if let Err(e) = written {
                println!("warning: cannot write {}: {e}", unavailable.display());
            }
        }
    }
    result
}

fn comparison_copy(root: &Path, dir: &Path, system: &Binary, apt: &mut Apt) -> Result<Outcome> {
    let system_major = system.major().ok_or_else(|| {
        format!(
            "the system's QEMU version `{}` has no major number",
            system.version
        )
    })?;
    if let Some(copy) = existing_copy(dir, system_major) {
        return Ok(Outcome {
            installed: false,
            item: format!(
                "QEMU {} for comparison ({})",
                copy.version,
                shown(root, &copy.program)
            ),
            detail: format!(
                "QEMU {} for comparison beside the system's {}: {} ({}; unpacked privately, \
                 not installed system-wide)",
                copy.version,
                system.version,
                shown(root, &copy.program),
                copy.line
            ),
        });
    }
    for tool in ["apt-get", "apt-cache", "dpkg-deb"] {
        if process::which(tool).is_none() {
            return Err(format!(
                "{tool} not found: no second QEMU version can be fetched"
            ));
        }
    }
    let other = |candidates: Vec<Candidate>| -> Option<Candidate> {
        candidates
            .into_iter()
            .filter(|c| apt::upstream_major(&c.version).is_some_and(|m| m != system_major))
            .reduce(|best, c| {
                if apt::newer(&c.version, &best.version) {
                    c
                } else {
                    best
                }
            })
    };
    let mut sources = None;
    let mut candidate = other(Apt::candidates(None, PACKAGE)?);
    if candidate.is_none() {
        let suite = apt::backports_suite(&apt::os_release()).ok_or_else(|| {
            format!(
                "this machine's apt sources offer no {PACKAGE} but QEMU {system_major}, and it \
                 is not a Debian release with a backports suite"
            )
        })?;
        println!(
            "this machine's apt sources offer no {PACKAGE} but QEMU {system_major}: reading \
             {suite} through a temporary source list (the machine's sources kept, /etc/apt \
             unchanged)"
        );
        let added = Sources::with_debian_suite(&suite)?;
        apt.update_with(&added)?;
        candidate = other(Apt::candidates(Some(&added), PACKAGE)?);
        sources = Some(added);
    }
    let candidate = candidate.ok_or_else(|| {
        format!("no {PACKAGE} of another major version than the system's QEMU {system_major}")
    })?;
    let directory = candidate
        .version
        .split_once(':')
        .map_or(candidate.version.as_str(), |(_, rest)| rest);
    let destination = dir.join(directory);
    println!(
        "missing: a second QEMU version for comparison (the system's is {}); unpacking {PACKAGE} \
         {} from {} into {} (apt-get download, dpkg-deb -x; nothing is installed system-wide)",
        system.version,
        candidate.version,
        candidate.suite,
        shown(root, &destination)
    );
    let download = dir.join(DOWNLOAD_DIR);
    let deb = Apt::download(sources.as_ref(), PACKAGE, &candidate.version, &download)?;
    let partial = dir.join(format!("{directory}.partial"));
    if partial.exists() {
        fs::remove_dir_all(&partial)
            .map_err(|e| format!("cannot remove {}: {e}", partial.display()))?;
    }
    process::run(Command::new("dpkg-deb").arg("-x").arg(&deb).arg(&partial))?;
    if destination.exists() {
        fs::remove_dir_all(&destination)
            .map_err(|e| format!("cannot remove {}: {e}", destination.display()))?;
    }
    fs::rename(&partial, &destination)
        .map_err(|e| format!("cannot move {} into place: {e}", partial.display()))?;
    // The .deb is unpacked; the copy is what remains.
    let _ = fs::remove_dir_all(&download);
    let binary = destination.join(COMPARISON_BINARY);
    let copy = Binary::probe(&binary).map_err(|e| {
        format!(
            "{PACKAGE} {} was unpacked but does not run: {e}",
            candidate.version
        )
    })?;
    Ok(Outcome {
        installed: true,
        item: format!(
            "QEMU {} for comparison ({})",
            copy.version,
            shown(root, &binary)
        ),
        detail: format!(
            "QEMU {} for comparison beside the system's {}: {} ({PACKAGE} {} from {}, \
             unpacked privately, not installed system-wide)",
            copy.version,
            system.version,
            shown(root, &binary),
            candidate.version,
            candidate.suite
        ),
    })
}

/// A copy under `dir` of another major version than `system_major` that runs.
fn existing_copy(dir: &Path, system_major: u32) -> Option<Binary> {
    let mut binaries: Vec<PathBuf> = fs::read_dir(dir)
        .ok()?
        .filter_map(|entry| entry.ok())
        .map(|entry| entry.path().join(COMPARISON_BINARY))
        .filter(|binary| binary.is_file())
        .collect();
    binaries.sort();
    binaries
        .iter()
        .filter_map(|binary| Binary::probe(binary).ok())
        .find(|copy| copy.major().is_some_and(|m| m != system_major))
}

/// `path` relative to `root` when it is inside it, for messages.
fn shown(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .display()
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::apt::Removal;

    fn removal(package: &str, version: &str) -> Removal {
        Removal {
            package: package.into(),
            version: version.into(),
        }
    }

    #[test]
    fn the_version_to_match_is_that_of_the_qemu_packages_in_the_way() {
        let bpo = "1:10.0.2+ds-2+deb13u1~bpo12+1";
        assert_eq!(
            matching_version(&[removal("qemu-utils", bpo)]).unwrap(),
            bpo
        );
        assert_eq!(
            matching_version(&[
                removal("qemu-utils", bpo),
                removal("qemu-block-extra", bpo),
                removal("libfoo1", "2.0-1"),
            ])
            .unwrap(),
            bpo
        );
        let err = matching_version(&[removal("libfoo1", "2.0-1")]).unwrap_err();
        assert!(err.contains("none of them is a QEMU package"), "{err}");
        let err = matching_version(&[
            removal("qemu-utils", bpo),
            removal("qemu-guest-agent", "1:7.2+dfsg-7"),
        ])
        .unwrap_err();
        assert!(err.contains("several versions"), "{err}");
    }

    const BPO: &str = "1:10.0.2+ds-2+deb13u1~bpo12+1";
    const BOOKWORM_72: &str = "1:7.2+dfsg-7+deb12u18+b3";
    const BOOKWORM: &str = "ID=debian\nVERSION_ID=\"12\"\nVERSION_CODENAME=bookworm\n";

    fn candidate(version: &str, suite: &str) -> Candidate {
        Candidate {
            version: version.into(),
            suite: suite.into(),
        }
    }

    /// A machine's apt as a script: what its sources offer, what each install
    /// would remove, and the installs it was asked to run.
    struct Script {
        machine: Vec<Candidate>,
        backports: Vec<Candidate>,
        removes: Vec<(String, Vec<Removal>)>,
        added: Option<String>,
        done: Vec<(Option<String>, Option<String>, String)>,
    }

    impl Script {
        fn new(removes: &[(&str, &[Removal])]) -> Self {
            Script {
                machine: vec![
                    candidate(BOOKWORM_72, "bookworm"),
                    candidate("1:7.2+dfsg-7+deb12u15", "bookworm-security"),
                ],
                backports: vec![candidate(BPO, "bookworm-backports")],
                removes: removes
                    .iter()
                    .map(|(spec, r)| ((*spec).to_owned(), r.to_vec()))
                    .collect(),
                added: None,
                done: Vec::new(),
            }
        }
    }

    impl Packages for Script {
        fn install(
            &mut self,
            release: Option<&str>,
            packages: &[&str],
        ) -> std::result::Result<Plan, InstallError> {
            let spec = packages.join(" ");
            let removals = self
                .removes
                .iter()
                .find(|(s, _)| *s == spec)
                .map(|(_, r)| r.clone())
                .unwrap_or_default();
            let version = spec.split_once('=').map_or(BOOKWORM_72, |(_, v)| v);
            let plan = Plan {
                installs: vec![(PACKAGE.into(), version.into())],
                removals,
            };
            if !plan.removals.is_empty() {
                return Err(InstallError::WouldRemove { plan });
            }
            self.done
                .push((self.added.clone(), release.map(str::to_owned), spec));
            Ok(plan)
        }

        fn candidates(&mut self, _package: &str) -> Result<Vec<Candidate>> {
            let mut offered = self.machine.clone();
            if self.added.is_some() {
                offered.extend(self.backports.clone());
            }
            Ok(offered)
        }

        fn add_suite(&mut self, suite: &str) -> Result<()> {
            self.added = Some(suite.to_owned());
            Ok(())
        }

        fn os_release(&self) -> String {
            BOOKWORM.into()
        }
    }

    #[test]
    fn debians_candidate_is_installed_when_it_removes_nothing() {
        let mut script = Script::new(&[]);
        let how = install(&mut script).unwrap();
        assert_eq!(how, "apt, Debian's candidate");
        assert_eq!(script.done, [(None, None, PACKAGE.to_owned())]);
    }

    #[test]
    fn a_backports_qemu_gets_the_matching_version_from_backports() {
        // The machine of issue 22: qemu-utils 10.0.2 from bookworm-backports, which
        // bookworm's qemu-system-arm 7.2 would remove.
        let utils = [removal("qemu-utils", BPO)];
        let mut script = Script::new(&[(PACKAGE, &utils)]);
        let how = install(&mut script).unwrap();
        assert_eq!(
            how,
            "apt, bookworm-backports, matching the installed QEMU packages"
        );
        assert_eq!(
            script.done,
            [(
                Some("bookworm-backports".to_owned()),
                Some("bookworm-backports".to_owned()),
                format!("{PACKAGE}={BPO}")
            )]
        );
    }

    #[test]
    fn a_matching_version_in_the_machines_sources_needs_no_added_suite() {
        let security = "1:7.2+dfsg-7+deb12u15";
        let utils = [removal("qemu-utils", security)];
        let mut script = Script::new(&[(PACKAGE, &utils)]);
        install(&mut script).unwrap();
        assert_eq!(
            script.done,
            [(
                None,
                Some("bookworm-security".to_owned()),
                format!("{PACKAGE}={security}")
            )]
        );
    }

    #[test]
    fn setup_stops_naming_what_every_way_would_remove() {
        let utils = [removal("qemu-utils", BPO)];
        let other = [removal("qemu-block-extra", BPO)];
        let matching = format!("{PACKAGE}={BPO}");
        let mut script = Script::new(&[(PACKAGE, &utils), (&matching, &other)]);
        let err = install(&mut script).unwrap_err();
        assert!(script.done.is_empty(), "nothing was installed");
        assert!(
            err.contains(&format!("{BOOKWORM_72} would remove qemu-utils {BPO}")),
            "{err}"
        );
        assert!(
            err.contains(&format!(
                "{BPO} from bookworm-backports would remove qemu-block-extra {BPO}"
            )),
            "{err}"
        );
        assert!(err.contains("Setup removes nothing"), "{err}");

        // A version that no known suite carries.
        let odd = [removal("qemu-utils", "1:9.9-local")];
        let mut script = Script::new(&[(PACKAGE, &odd)]);
        let err = install(&mut script).unwrap_err();
        assert!(err.contains("qemu-utils 1:9.9-local"), "{err}");
        assert!(err.contains("not a backport of this release"), "{err}");
        assert!(script.done.is_empty());
    }

    #[test]
    fn an_existing_copy_of_the_same_major_version_does_not_count() {
        let dir = std::env::temp_dir().join(format!("xtask-qemu-test-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        let bin = dir.join("7.2+dfsg-7").join("usr/bin");
        fs::create_dir_all(&bin).unwrap();
        let script = bin.join("qemu-system-arm");
        fs::write(
            &script,
            "#!/bin/sh\necho 'QEMU emulator version 7.2.22 (Debian 1:7.2+dfsg-7)'\n",
        )
        .unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            fs::set_permissions(&script, fs::Permissions::from_mode(0o755)).unwrap();
        }
        let found = existing_copy(&dir, 10).expect("the 7.2 copy beside a system 10");
        assert_eq!(found.version, "7.2.22");
        assert!(existing_copy(&dir, 7).is_none());
        fs::remove_dir_all(&dir).unwrap();
    }
}
