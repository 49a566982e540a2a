//! Building the firmware and reading its ELF.
//!
//! The firmware is a Cargo workspace of its own (`firmware/`, target
//! `thumbv7em-none-eabihf`, set in `firmware/.cargo/config.toml`). It is built with
//! the toolchain `cargo xtask setup` chose: the rustup toolchain, or, when
//! `target/xtask-toolchain` says `debian`, Debian's compiler with `core` built from
//! source (docs/toolchain.md §1).

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use object::{Object, ObjectSection, SectionFlags, SectionKind};

use decoy_boards::Build;

use crate::qemu::{Board, Captured, RunError, run_with_timeout};

/// The firmware's binary name.
pub use decoy_boards::BINARY;
/// The bare-metal target of the firmware (every board's).
pub use decoy_boards::TARGET;

/// Time limit of a firmware build (`decoy hil`, the bridge's qemu backend, the
/// step-cost measurement).
pub const BUILD_TIMEOUT: Duration = Duration::from_secs(900);

/// The environment variable naming the checkout whose `firmware/` is built (for
/// a `decoy` installed away from its checkout).
pub const SOURCE_ENV: &str = "DECOY_SOURCE_DIR";

/// The repository root whose `firmware/` is built: [`SOURCE_ENV`] if set, else the
/// checkout this program was built from.
pub fn workspace_root() -> PathBuf {
    if let Some(dir) = std::env::var_os(SOURCE_ENV) {
        return PathBuf::from(dir);
    }
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// The firmware's source directory, checked to hold the firmware's manifest;
/// [`BuildError::NoSource`] says what to do otherwise.
pub fn locate_source() -> Result<PathBuf, BuildError> {
    let dir = firmware_dir();
    let manifest = dir.join("Cargo.toml");
    let is_firmware = fs::read_to_string(&manifest)
        .is_ok_and(|text| text.contains(&format!("name = \"{BINARY}\"")));
    if is_firmware {
        Ok(dir)
    } else {
        Err(BuildError::NoSource(dir))
    }
}

/// Checks that `path` is an ELF file (the `--firmware` argument).
pub fn check_elf(path: &Path) -> Result<(), BuildError> {
    let mut magic = [0u8; 4];
    let is_elf = fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
        .is_ok()
        && magic == *b"\x7fELF";
    if is_elf {
        Ok(())
    } else {
        Err(BuildError::NotElf(path.to_path_buf()))
    }
}

/// The firmware workspace.
pub fn firmware_dir() -> PathBuf {
    workspace_root().join("firmware")
}

/// The target directory of `board`'s QEMU build in the firmware workspace at
/// `firmware` (`decoy_boards::BoardSpec::target_subdir`): Cargo's own `target/`
/// for the default board, `target/NAME/` for the others, so that the boards do
/// not rebuild each other.
fn target_dir_in(firmware: &Path, board: Board) -> PathBuf {
    match board.target_subdir(Build::Qemu) {
        Some(subdir) => firmware.join(subdir),
        None => firmware.join("target"),
    }
}

/// The ELF that [`build_board`] produces for `board`
/// (`firmware/target/[NAME/]thumbv7em-none-eabihf/release/decoy-firmware`).
pub fn release_elf(board: Board) -> PathBuf {
    target_dir_in(&firmware_dir(), board)
        .join(TARGET)
        .join("release")
        .join(BINARY)
}

/// The cargo arguments of `board`'s QEMU build
/// (`decoy_boards::BoardSpec::cargo_args`: its features and target CPU, from
/// `firmware/boards.toml`).
pub fn board_args(board: Board) -> Vec<String> {
    // Every board of the table has a QEMU build.
    board.cargo_args(Build::Qemu).unwrap_or_default()
}

/// Why the firmware could not be built.
#[derive(Debug)]
pub enum BuildError {
    /// Cargo could not be run, or ran out of time.
    Run(RunError),
    /// Cargo ran and failed.
    Failed(Captured),
    /// Cargo succeeded but the ELF is not where expected.
    MissingElf(PathBuf),
    /// The sources of a [`build_with_segments`] variant could not be prepared.
    Variant(String),
    /// No firmware source where it was looked for.
    NoSource(PathBuf),
    /// A `--firmware` file that is not an ELF (or cannot be read).
    NotElf(PathBuf),
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::Run(e) => write!(f, "building the firmware: {e}"),
            BuildError::Failed(out) => write!(
                f,
                "the firmware build failed (run `cargo xtask setup` if the target is missing)\n{}",
                out.describe()
            ),
            BuildError::MissingElf(path) => {
                write!(
                    f,
                    "the firmware build succeeded but {} does not exist",
                    path.display()
                )
            }
            BuildError::Variant(message) => f.write_str(message),
            BuildError::NoSource(dir) => write!(
                f,
                "no firmware source at {} (this `decoy` was built elsewhere): pass --firmware ELF, \
                 or set {SOURCE_ENV} to a checkout of the project",
                dir.display()
            ),
            BuildError::NotElf(path) => {
                write!(f, "--firmware {}: not a readable ELF file", path.display())
            }
        }
    }
}

impl std::error::Error for BuildError {}

/// How `cargo xtask setup` said target code must be built.
fn debian_toolchain() -> bool {
    fs::read_to_string(workspace_root().join("target").join("xtask-toolchain"))
        .is_ok_and(|mode| mode.trim() == "debian")
}

/// A `cargo build --release` command of the firmware workspace at `dir` (the
/// firmware itself, or a [`build_with_segments`] copy of it) with `extra` cargo
/// arguments (a board's, [`board_args`]).
///
/// It runs in `dir` so that its `.cargo/config.toml` (target, runner) applies,
/// with `--manifest-path` for clarity. Variables that would override that
/// configuration when inherited from an outer `cargo test` (`RUSTFLAGS`, a
/// shared target directory, a build target) are removed.
fn build_command_with<S: AsRef<std::ffi::OsStr>>(dir: &Path, extra: &[S]) -> Command {
    let manifest = dir.join("Cargo.toml");
    let mut cmd = if debian_toolchain() {
        let mut cmd = Command::new("rustup");
        cmd.args(["run", "debian", "cargo", "build", "--release"])
            .args([
                "-Z",
                "build-std=core,compiler_builtins",
                "-Z",
                "build-std-features=compiler-builtins-mem",
            ])
            .env("RUSTC_BOOTSTRAP", "1");
        cmd
    } else {
        let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
        cmd.args(["build", "--release"]);
        cmd
    };
    cmd.args(extra)
        .arg("--manifest-path")
        .arg(manifest)
        .current_dir(dir);
    for var in [
        "RUSTFLAGS",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_BUILD_RUSTFLAGS",
        "CARGO_BUILD_TARGET",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET_DIR",
    ] {
        cmd.env_remove(var);
    }
    cmd
}

/// Builds the firmware for `board` within `timeout` and returns its ELF: the
/// board's QEMU build as `firmware/boards.toml` describes it ([`board_args`]),
/// in its own target directory ([`release_elf`]).
pub fn build_board(board: Board, timeout: Duration) -> Result<PathBuf, BuildError> {
    let (release, mut cmd) = board_build(board, &[]);
    run_build(&mut cmd, timeout, release.join(BINARY))
}

/// The release output directory of `board`'s build of the firmware workspace and
/// the command that builds it with `extra` cargo arguments.
fn board_build(board: Board, extra: &[&str]) -> (PathBuf, Command) {
    let target_dir = target_dir_in(&firmware_dir(), board);
    let mut args = board_args(board);
    args.extend(extra.iter().map(|&a| a.to_owned()));
    let mut cmd = build_command_with(&firmware_dir(), &args);
    cmd.arg("--target-dir").arg(&target_dir);
    (target_dir.join(TARGET).join("release"), cmd)
}

/// Builds the firmware's example `name` (`firmware/examples/<name>.rs`) for
/// `board` within `timeout` and returns its ELF (M4: the default build's target
/// directory; the others: their profile's).
pub fn build_example(board: Board, name: &str, timeout: Duration) -> Result<PathBuf, BuildError> {
    let (release, mut cmd) = board_build(board, &["--example", name]);
    run_build(&mut cmd, timeout, release.join("examples").join(name))
}

/// Runs a firmware build and checks that it produced `elf`.
fn run_build(cmd: &mut Command, timeout: Duration, elf: PathBuf) -> Result<PathBuf, BuildError> {
    let out = run_with_timeout(
        cmd,
        timeout,
        "cargo is not on PATH; install Rust with rustup",
    )
    .map_err(BuildError::Run)?;
    if !out.status.success() {
        return Err(BuildError::Failed(out));
    }
    if elf.is_file() {
        Ok(elf)
    } else {
        Err(BuildError::MissingElf(elf))
    }
}

/// [`build_with_segments`] for `board`: each board's variants have their own
/// target directory (`target/firmware-variants/target` for the default board,
/// `target-NAME` for the others) and ELF names (`decoy-firmware-<segments>seg`,
/// `decoy-firmware-NAME-<segments>seg`). Errors if `segments` is 0 or more than
/// [`MAX_SEGMENTS`].
pub fn build_board_with_segments(
    board: Board,
    segments: usize,
    timeout: Duration,
) -> Result<PathBuf, BuildError> {
    if !(1..=MAX_SEGMENTS).contains(&segments) {
        return Err(BuildError::Variant(format!(
            "the firmware's solver holds 1 to {MAX_SEGMENTS} segments, not {segments}"
        )));
    }
    let variants = variants_dir();
    let root = variants.join(format!("segments-{segments}"));
    prepare_variant(&root, segments, None).map_err(|e| {
        BuildError::Variant(format!(
            "preparing the sources for the {segments}-segment firmware: {e}"
        ))
    })?;
    let target_dir = variant_target_dir(board);
    let mut cmd = build_command_with(&root.join("firmware"), &board_args(board));
    cmd.arg("--target-dir").arg(&target_dir);
    let built = run_build(
        &mut cmd,
        timeout,
        target_dir.join(TARGET).join("release").join(BINARY),
    )?;
    let elf = if board.is_default() {
        variants.join(format!("{BINARY}-{segments}seg"))
    } else {
        variants.join(format!("{BINARY}-{board}-{segments}seg"))
    };
    fs::copy(&built, &elf).map_err(|e| {
        BuildError::Variant(format!("copying the {segments}-segment {board} ELF: {e}"))
    })?;
    Ok(elf)
}

/// The shared target directory of `board`'s variants under [`variants_dir`]:
/// `target` for the default board, `target-NAME` for the others.
fn variant_target_dir(board: Board) -> PathBuf {
    if board.is_default() {
        variants_dir().join("target")
    } else {
        variants_dir().join(format!("target-{board}"))
    }
}

/// [`build_board_with_segments`] with the grading ratio replaced too (for the
/// benchmark report, which keeps the shortest segment of larger models as long as
/// the configured model's). The variant lives in
/// `target/firmware-variants/segments-<n>-graded-<ratio>/`.
pub fn build_board_with_layout(
    board: Board,
    segments: usize,
    grading: f64,
    timeout: Duration,
) -> Result<PathBuf, BuildError> {
    if !((1..=MAX_SEGMENTS).contains(&segments) && grading.is_finite() && grading >= 1.0) {
        return Err(BuildError::Variant(format!(
            "the firmware's solver holds 1 to {MAX_SEGMENTS} segments graded by a ratio of \
             at least 1, not {segments} graded {grading}"
        )));
    }
    let variants = variants_dir();
    let name = format!("segments-{segments}-graded-{grading:?}");
    let root = variants.join(&name);
    prepare_variant(&root, segments, Some(grading))
        .map_err(|e| BuildError::Variant(format!("preparing the sources of {name}: {e}")))?;
    let target_dir = variant_target_dir(board);
    let mut cmd = build_command_with(&root.join("firmware"), &board_args(board));
    cmd.arg("--target-dir").arg(&target_dir);
    let built = run_build(
        &mut cmd,
        timeout,
        target_dir.join(TARGET).join("release").join(BINARY),
    )?;
    let elf = variants.join(format!("{BINARY}-{board}-{name}"));
    fs::copy(&built, &elf)
        .map_err(|e| BuildError::Variant(format!("copying the ELF of {name}: {e}")))?;
    Ok(elf)
}

/// The segment counts [`build_with_segments`] accepts: the firmware's solver has
/// room for [`crate::flight::CONTROLLER_CAPACITY`] segments.
pub const MAX_SEGMENTS: usize = crate::flight::CONTROLLER_CAPACITY;

/// Where [`build_with_segments`] puts its copies, their shared target directory and
/// the ELFs: `target/firmware-variants/` of the root workspace.
pub fn variants_dir() -> PathBuf {
    workspace_root().join("target").join("firmware-variants")
}

/// Builds the firmware, unchanged, for a reference system with `segments` graded
/// segments instead of the configured `solver.segments_embedded`, and returns the
/// ELF (`target/firmware-variants/decoy-firmware-<segments>seg`).
///
/// The firmware takes its segment count from `config/reference-system.toml` at
/// build time (`firmware/build.rs` reads `../config/reference-system.toml`). This
/// copies the firmware's sources into
/// `target/firmware-variants/segments-<n>/firmware/`, writes beside them a
/// `config/` whose `segments_embedded` line says `segments` (all other values and
/// the aerodynamic table unchanged), links `crates/` to the workspace's crates, adds
/// an empty `[workspace]` table to the copied manifest (the root manifest excludes
/// only `firmware/` itself), and builds there (shared target directory `target/firmware-variants/target`, so the
/// dependencies build once). Neither `firmware/` nor `config/` is modified.
///
/// Panics if `segments` is 0 or more than [`MAX_SEGMENTS`].
pub fn build_with_segments(segments: usize, timeout: Duration) -> Result<PathBuf, BuildError> {
    assert!(
        (1..=MAX_SEGMENTS).contains(&segments),
        "the firmware's solver holds 1 to {MAX_SEGMENTS} segments, not {segments}"
    );
    build_board_with_segments(Board::default(), segments, timeout)
}

/// Lays out `root/{firmware,config,crates}` for [`build_with_segments`]. Files are
/// rewritten only when their content changes, so repeated builds stay incremental.
fn prepare_variant(root: &Path, segments: usize, grading: Option<f64>) -> std::io::Result<()> {
    let workspace = workspace_root();
    copy_tree(
        &firmware_dir(),
        &root.join("firmware"),
        &["target", "Cargo.toml"],
    )?;
    // `firmware/` is a workspace of its own because the root manifest excludes it;
    // the copy sits under the root workspace's directory, so it says so itself.
    // Its path dependencies point at the workspace's crates themselves (not through
    // the `crates` link below): decoy-link inherits solver-core from the root
    // workspace, and two paths to one package collide in the lockfile.
    let crates = workspace.join("crates");
    let manifest = fs::read_to_string(firmware_dir().join("Cargo.toml"))?
        .replace("\"../crates/", &format!("\"{}/", crates.display()));
    write_if_changed(
        &root.join("firmware").join("Cargo.toml"),
        format!("{manifest}\n# Added by decoy_hil::firmware::build_with_segments.\n[workspace]\n")
            .as_bytes(),
    )?;
    let config = workspace.join("config");
    copy_tree(&config, &root.join("config"), &[])?;
    let toml_path = root.join("config").join("reference-system.toml");
    let text = fs::read_to_string(config.join("reference-system.toml"))?;
    let mut replaced = with_segments(&text, segments).ok_or_else(|| {
        std::io::Error::other("config/reference-system.toml has no `segments_embedded =` line")
    })?;
    if let Some(ratio) = grading {
        replaced = with_value(&replaced, "grading_ratio_embedded", &format!("{ratio:?}"))
            .ok_or_else(|| {
                std::io::Error::other(
                    "config/reference-system.toml has no `grading_ratio_embedded =` line",
                )
            })?;
    }
    write_if_changed(&toml_path, replaced.as_bytes())?;
    let link = root.join("crates");
    if fs::read_link(&link).ok().as_deref() != Some(workspace.join("crates").as_path()) {
        // A stale link or a leftover directory: replace it.
        let _ = fs::remove_file(&link);
        let _ = fs::remove_dir_all(&link);
        std::os::unix::fs::symlink(workspace.join("crates"), &link)?;
    }
    Ok(())
}

/// `text` (the reference-system TOML) with its `segments_embedded` value replaced
/// by `segments`, its comment kept; `None` if there is no such line.
pub fn with_segments(text: &str, segments: usize) -> Option<String> {
    with_value(text, "segments_embedded", &segments.to_string())
}

/// `text` (the reference-system TOML) with the value of its first `key = ...` line
/// replaced by `value`, its comment kept; `None` if there is no such line.
pub fn with_value(text: &str, key_wanted: &str, value: &str) -> Option<String> {
    let mut found = false;
    let lines: Vec<String> = text
        .lines()
        .map(|line| {
            let trimmed = line.trim_start();
            let key = trimmed.split('=').next().unwrap_or("").trim();
            if key == key_wanted && !found {
                found = true;
                let comment = line.find('#').map(|i| &line[i..]).unwrap_or("");
                let indent = &line[..line.len() - trimmed.len()];
                format!("{indent}{key_wanted} = {value} {comment}")
                    .trim_end()
                    .to_owned()
            } else {
                line.to_owned()
            }
        })
        .collect();
    found.then(|| lines.join("\n") + "\n")
}

/// Copies the files under `from` to `to` (creating directories), skipping the
/// top-level entries named in `skip`; unchanged files are left untouched.
fn copy_tree(from: &Path, to: &Path, skip: &[&str]) -> std::io::Result<()> {
    fs::create_dir_all(to)?;
    for entry in fs::read_dir(from)? {
        let entry = entry?;
        let name = entry.file_name();
        if skip.iter().any(|s| name == *s) {
            continue;
        }
        let (source, dest) = (entry.path(), to.join(&name));
        if entry.file_type()?.is_dir() {
            copy_tree(&source, &dest, &[])?;
        } else {
            write_if_changed(&dest, &fs::read(&source)?)?;
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` unless it already holds exactly them.
fn write_if_changed(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if fs::read(path).is_ok_and(|old| old == bytes) {
        return Ok(());
    }
    fs::write(path, bytes)
}

/// Static memory of an ELF, as `size` (Berkeley format) counts it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryUsage {
    /// Read-only allocated sections: code, constants, vector table (flash), bytes.
    pub text: u64,
    /// Initialised writable sections (flash image, copied to RAM), bytes.
    pub data: u64,
    /// Zero-initialised and uninitialised writable sections (RAM), bytes.
    pub bss: u64,
}

impl MemoryUsage {
    /// Flash used: `.text` + `.data`'s load image.
    pub fn flash(&self) -> u64 {
        self.text + self.data
    }

    /// Static RAM used: `.data` + `.bss` (the stack comes on top).
    pub fn ram(&self) -> u64 {
        self.data + self.bss
    }
}

impl fmt::Display for MemoryUsage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "text {} B, data {} B, bss {} B (flash {} B, static RAM {} B)",
            self.text,
            self.data,
            self.bss,
            self.flash(),
            self.ram()
        )
    }
}

/// What a firmware's log says of its memory: the stack high-water marks that
/// stack painting measured (`firmware/src/board/common.rs`) and the controller's
/// size from the boot banner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StackMarks {
    /// The deepest the stack got from reset until the controller was built (the
    /// line `boot stack high-water N B`), bytes.
    pub boot: u64,
    /// The deepest the stack got in the link loop (painted again after the boot),
    /// at the last line that reports it (`stack=N`: the trim and every 100th
    /// output), bytes; None before any such line.
    pub link: Option<u64>,
    /// Size of the controller with its solver (the banner's `controller N B`),
    /// bytes: it lies in `.bss`.
    pub controller: u64,
}

impl StackMarks {
    /// The deepest stack of the run: the boot's or the link loop's.
    pub fn peak(&self) -> u64 {
        self.boot.max(self.link.unwrap_or(0))
    }
}

/// Reads the [`StackMarks`] from a firmware's decoded log.
pub fn stack_marks(log: &str) -> Result<StackMarks, String> {
    /// The number right after the first `key` in `line`.
    fn number_after(line: &str, key: &str) -> Option<u64> {
        let (_, rest) = line.split_once(key)?;
        let digits: &str = rest
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .filter(|d| !d.is_empty())?;
        digits.parse().ok()
    }
    let boot = log
        .lines()
        .find_map(|line| number_after(line, "boot stack high-water "))
        .ok_or_else(|| format!("no `boot stack high-water` line in the firmware's log:\n{log}"))?;
    let controller = log
        .lines()
        .find_map(|line| number_after(line, ", controller "))
        .ok_or_else(|| {
            format!("no banner with the controller's size in the firmware's log:\n{log}")
        })?;
    // The high-water mark only grows: the last report is the deepest.
    let link = log
        .lines()
        .filter_map(|line| number_after(line, " stack="))
        .max();
    Ok(StackMarks {
        boot,
        link,
        controller,
    })
}

/// Reads the allocated sections of the ELF at `path`.
pub fn memory_usage(path: &Path) -> Result<MemoryUsage, String> {
    let bytes = fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut usage = MemoryUsage::default();
    for section in file.sections() {
        let SectionFlags::Elf { sh_flags } = section.flags() else {
            continue;
        };
        let alloc = sh_flags & u64::from(object::elf::SHF_ALLOC) != 0;
        if !alloc {
            continue;
        }
        let write = sh_flags & u64::from(object::elf::SHF_WRITE) != 0;
        let zero_fill = matches!(
            section.kind(),
            SectionKind::UninitializedData | SectionKind::UninitializedTls
        );
        let size = section.size();
        match (write, zero_fill) {
            (_, true) => usage.bss += size,
            (true, false) => usage.data += size,
            (false, false) => usage.text += size,
        }
    }
    Ok(usage)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_marks_are_read_from_the_log() {
        let log = "INFO  decoy controller: board mps2-an500, f64, 16 segments (capacity 64), controller 37536 B, stack room 4153000 B, protocol 2\n\
                   INFO  boot stack high-water 6208 B\n\
                   INFO  seq=0 t=0 T0=255.1 TN=50.2 steps=0 instr=2212360 flags=0x1 stack=14020\n\
                   INFO  seq=100 t=1 T0=255.1 TN=50.2 steps=2 instr=125040 flags=0x1 stack=15024\n";
        let marks = stack_marks(log).unwrap();
        assert_eq!(
            marks,
            StackMarks {
                boot: 6208,
                link: Some(15024),
                controller: 37536
            }
        );
        assert_eq!(marks.peak(), 15024);
        assert!(stack_marks("INFO  seq=0 stack=1").is_err());
    }

    #[test]
    fn segments_line_is_replaced_and_nothing_else() {
        let text = "[solver]\nsegments_host = 300\nsegments_embedded = 16       # reduced\nx = 1\n";
        let out = with_segments(text, 32).unwrap();
        assert_eq!(
            out,
            "[solver]\nsegments_host = 300\nsegments_embedded = 32 # reduced\nx = 1\n"
        );
        assert!(with_segments("[solver]\nsegments_host = 300\n", 8).is_none());
    }

    #[test]
    fn the_real_configuration_has_the_line() {
        let text = fs::read_to_string(workspace_root().join("config/reference-system.toml"))
            .expect("config/reference-system.toml");
        let out = with_segments(&text, 8).unwrap();
        assert!(out.contains("segments_embedded = 8 "), "{out}");
        assert_eq!(out.lines().count(), text.lines().count());
    }
}
