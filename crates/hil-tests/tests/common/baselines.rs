//! The measured baselines: `crates/hil-tests/baselines.toml`, one generated
//! file with what the HIL tests measured, per board (the names of
//! `firmware/boards.toml`) and per thing measured, each entry stamped with the
//! date, the commit and the command it was measured with.
//!
//! Every test that measures does two things with a measurement: it holds it to
//! its budget (`decoy_hil::budgets`: a hard limit, "over the budget: X > Y
//! (issue N)"), then to its baseline here, as a ratchet ([`Ratchet`]): worse
//! than the baseline by more than the stated [`Margin`] fails, naming the
//! measurement, the baseline and `cargo xtask bless`; better by more than
//! [`NOTE_BELOW`] passes with a note on stderr asking for a bless, so that the
//! baseline follows the improvement.
//!
//! The counts repeat exactly (QEMU `-icount`, the ELF's sections, stack
//! painting: run after run and under every QEMU version,
//! `tests/qemu_versions.rs`), so a margin is never for noise. Instruction
//! counts and bytes get [`COUNT_MARGIN`], 0.5 % (about 440 instructions of a
//! frame, two 40-instruction ticks of the M4's RK4 step, some 90 bytes of RAM
//! peak): a change that moves them by a few instructions or bytes (code
//! layout, one more check) needs no bless, one that costs more fails, and
//! because the baseline does not move with it, small regressions cannot add up
//! past it unblessed. A panic branch gets none ([`Margin::Exact`]).
//!
//! With `DECOY_BLESS=1` (what `cargo xtask bless` sets) the tests write their
//! measurements here instead of comparing them ([`record`]): each entry is
//! replaced under a file lock, so the tests of one binary and several binaries
//! may bless at once, and what was not measured is kept (`cargo xtask bless
//! --only NAME`). The budgets are asserted in both modes: a measurement over
//! its budget is never blessed.

use std::fmt::Write as _;
use std::fs::OpenOptions;
use std::io::{Read as _, Seek as _, SeekFrom, Write as _};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{SystemTime, UNIX_EPOCH};

use decoy_hil::qemu::Board;
use toml::{Table, Value};

/// The file, relative to the repository's root.
pub const FILE: &str = "crates/hil-tests/baselines.toml";
/// The documents with tables generated from the file (`tests/baselines.rs`),
/// relative to the repository's root.
pub const DOCUMENTS: &[&str] = &["README.md", "firmware/README.md"];
/// The environment variable that makes the tests write their measurements.
pub const BLESS_ENV: &str = "DECOY_BLESS";
/// The environment variable with the command that blesses (set by `cargo
/// xtask bless`; recorded in each entry's `measured`).
pub const COMMAND_ENV: &str = "DECOY_BLESS_COMMAND";
/// What a failure tells to run.
pub const BLESS: &str = "cargo xtask bless";
/// A measurement this much below its baseline (relative) prints a note asking
/// for a bless.
pub const NOTE_BELOW: f64 = 0.02;
/// How far above its baseline an instruction count or a number of bytes may be
/// (see the module's text).
pub const COUNT_MARGIN: Margin = Margin::Relative(COUNT_MARGIN_FRACTION);
/// [`COUNT_MARGIN`] as a fraction of the baseline.
pub const COUNT_MARGIN_FRACTION: f64 = 0.005;
/// The key of each entry's stamp.
pub const MEASURED: &str = "measured";
/// The sections, in the file's order (others follow, alphabetically).
pub const SECTIONS: &[&str] = &[
    "step_cost",
    "memory",
    "panic_sites",
    "envelope",
    "host_accuracy",
];

/// The file's path.
pub fn path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("baselines.toml")
}

/// The repository's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Whether the tests write their measurements (`DECOY_BLESS` set, and not
/// to `0` or nothing).
pub fn blessing() -> bool {
    std::env::var_os(BLESS_ENV).is_some_and(|v| !v.is_empty() && v != "0")
}

/// The file as read (once per test binary).
///
/// # Panics
///
/// If it cannot be read or is not TOML: the message names the file.
pub fn file() -> &'static Table {
    static FILE_TABLE: OnceLock<Table> = OnceLock::new();
    FILE_TABLE.get_or_init(|| {
        let path = path();
        let text = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{FILE}: {e} (run `{BLESS}` to measure and write it)"));
        text.parse::<Table>()
            .unwrap_or_else(|e| panic!("{FILE} is not valid TOML: {e}"))
    })
}

/// The table at `path` in `table` (`["envelope", "m4"]`), if there is one.
pub fn table_at<'a>(table: &'a Table, path: &[&str]) -> Option<&'a Table> {
    path.iter()
        .try_fold(table, |t, key| t.get(*key).and_then(Value::as_table))
}

/// `path` as the file names it (`envelope.m4`).
pub fn dotted(path: &[&str]) -> String {
    path.iter()
        .map(|k| key(k))
        .collect::<Vec<String>>()
        .join(".")
}

/// A number of the file (an integer or a float) as f64.
pub fn number(value: &Value) -> Option<f64> {
    match value {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

/// How far above its baseline a measurement may be before the ratchet fails.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Margin {
    /// Not at all (a panic branch: one more fails).
    Exact,
    /// By this much.
    Absolute(f64),
    /// By this fraction of the baseline.
    Relative(f64),
}

impl Margin {
    fn allowance(self, baseline: f64) -> f64 {
        match self {
            Margin::Exact => 0.0,
            Margin::Absolute(a) => a,
            Margin::Relative(r) => r * baseline.abs(),
        }
    }
}

/// The comparison of one entry's measurements with their baselines: failures
/// are gathered and reported together by [`Ratchet::finish`].
pub struct Ratchet {
    what: String,
    entry: Option<&'static Table>,
    failures: Vec<String>,
    notes: Vec<String>,
}

impl Ratchet {
    /// The comparison with the entry at `path` of the file (a missing entry
    /// fails each measurement with a message to bless); `what` names what was
    /// measured in messages (`m4: steady 0 m Mach 0.30`).
    pub fn new(path: &[&str], what: impl Into<String>) -> Self {
        Ratchet::with_entry(table_at(file(), path), &dotted(path), what)
    }

    /// The comparison with one inline entry `name` of the table at `path`
    /// (an envelope flight, a manoeuvre).
    pub fn inline(path: &[&str], name: &str, what: impl Into<String>) -> Self {
        let entry = table_at(file(), path).and_then(|t| t.get(name)?.as_table());
        let mut place = dotted(path);
        place.push('.');
        place.push_str(&key(name));
        Ratchet::with_entry(entry, &place, what)
    }

    fn with_entry(entry: Option<&'static Table>, place: &str, what: impl Into<String>) -> Self {
        let what = what.into();
        let mut failures = Vec::new();
        if entry.is_none() {
            failures.push(format!(
                "{what}: no baseline `{place}` in {FILE}: run `{BLESS}` to measure it"
            ));
        }
        Ratchet {
            what,
            entry,
            failures,
            notes: Vec::new(),
        }
    }

    /// The baseline of `name`, if the entry has it.
    pub fn baseline(&self, name: &str) -> Option<f64> {
        self.entry.and_then(|e| e.get(name)).and_then(number)
    }

    /// `measured` (a cost: lower is better; compared by magnitude, so a signed
    /// error counts by its size) against the baseline `name`: more than
    /// `margin` above it fails; more than [`NOTE_BELOW`] below it notes.
    pub fn at_most(&mut self, name: &str, measured: f64, margin: Margin) {
        let Some(entry) = self.entry else {
            return;
        };
        let Some(baseline) = entry.get(name).and_then(number) else {
            self.failures.push(format!(
                "{}: no baseline for `{name}` in {FILE}: run `{BLESS}` to measure it",
                self.what
            ));
            return;
        };
        let (m, b) = (measured.abs(), baseline.abs());
        if m > b + margin.allowance(baseline) {
            let allowed = match margin {
                Margin::Exact => String::new(),
                _ => format!(" by more than {}", show(margin.allowance(baseline))),
            };
            self.failures.push(format!(
                "{}: {name} {} is above its baseline {}{allowed} ({FILE}): run `{BLESS}` if \
                 intended",
                self.what,
                show(measured),
                show(baseline)
            ));
        } else if m < b * (1.0 - NOTE_BELOW) {
            self.notes.push(format!(
                "{}: {name} {} is {:.1} % below its baseline {}: run `{BLESS}` to lower it",
                self.what,
                show(measured),
                100.0 * (1.0 - m / b),
                show(baseline)
            ));
        }
    }

    /// Notes every baseline of the entry that is not among `measured` (gone:
    /// a bless drops it).
    pub fn note_gone(&mut self, measured: &[&str]) {
        let Some(entry) = self.entry else {
            return;
        };
        for name in entry.keys() {
            if name != MEASURED && !measured.contains(&name.as_str()) {
                self.notes.push(format!(
                    "{}: {name} has a baseline but was not measured: run `{BLESS}` to drop it",
                    self.what
                ));
            }
        }
    }

    /// An instruction count or a number of bytes against its baseline, within
    /// [`COUNT_MARGIN`].
    pub fn count(&mut self, name: &str, measured: impl Into<u64>) {
        self.at_most(name, measured.into() as f64, COUNT_MARGIN);
    }

    /// Prints the notes (to the process's stderr, which the test harness does
    /// not capture) and returns the failures, for a test that gathers those of
    /// several entries.
    pub fn end(self) -> Vec<String> {
        note(&self.notes);
        self.failures
    }

    /// Prints the notes and fails with every failure.
    ///
    /// # Panics
    ///
    /// If a measurement was over its baseline or had none.
    pub fn finish(self) {
        assert_within_baselines(&self.end());
    }
}

/// Fails with `failures` (of [`Ratchet::end`]), if any.
///
/// # Panics
///
/// If there is a failure.
pub fn assert_within_baselines(failures: &[String]) {
    assert!(
        failures.is_empty(),
        "over the baseline:\n{}",
        failures.join("\n")
    );
}

/// Writes `notes` to the process's stderr (not captured by the harness).
pub fn note(notes: &[String]) {
    if notes.is_empty() {
        return;
    }
    let mut err = std::io::stderr().lock();
    for n in notes {
        let _ = writeln!(err, "note: {n}");
    }
}

/// A number as the messages show it: an integer without a fraction, else with
/// enough digits.
fn show(x: f64) -> String {
    if x.fract() == 0.0 && x.abs() < 1e15 {
        format!("{x:.0}")
    } else {
        format!("{x}")
    }
}

/// Writes a measurement: the entry at `path` (`["step_cost", "m4"]`, or
/// `["host_accuracy"]`) as `update` leaves it, stamped with [`MEASURED`]
/// (date, commit, command). The file is locked while it is read, changed and
/// written. In a per-board section (a path of two keys), the entries of boards
/// no longer in `firmware/boards.toml` are dropped.
///
/// # Panics
///
/// If the file cannot be locked, read, parsed or written.
pub fn record(path: &[&str], update: impl FnOnce(&mut Table)) {
    let file_path = self::path();
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&file_path)
        .unwrap_or_else(|e| panic!("{FILE}: {e}"));
    file.lock().unwrap_or_else(|e| panic!("{FILE}: lock: {e}"));
    let mut text = String::new();
    file.read_to_string(&mut text)
        .unwrap_or_else(|e| panic!("{FILE}: {e}"));
    let mut root: Table = text
        .parse()
        .unwrap_or_else(|e| panic!("{FILE} is not valid TOML: {e}"));
    let mut table = &mut root;
    for (depth, key) in path.iter().enumerate() {
        if depth == 1 {
            table.retain(|k, _| Board::by_name(k).is_ok() || k == *key);
        }
        table = table
            .entry(key.to_string())
            .or_insert_with(|| Value::Table(Table::new()))
            .as_table_mut()
            .unwrap_or_else(|| panic!("{FILE}: `{}` is not a table", dotted(path)));
    }
    update(table);
    table.insert(MEASURED.to_owned(), Value::Table(stamp()));
    let text = render(&root);
    file.seek(SeekFrom::Start(0))
        .and_then(|_| file.set_len(0))
        .and_then(|()| file.write_all(text.as_bytes()))
        .and_then(|()| file.flush())
        .unwrap_or_else(|e| panic!("{FILE}: {e}"));
}

/// `measured = { date, commit, command }` of this process's blessing.
fn stamp() -> Table {
    static STAMP: OnceLock<Table> = OnceLock::new();
    STAMP
        .get_or_init(|| {
            let command = std::env::var(COMMAND_ENV).unwrap_or_else(|_| {
                format!(
                    "{BLESS_ENV}=1 cargo test -p hil-tests --test {}",
                    env!("CARGO_CRATE_NAME")
                )
            });
            let mut t = Table::new();
            t.insert("date".into(), Value::String(today()));
            t.insert("commit".into(), Value::String(commit()));
            t.insert("command".into(), Value::String(command));
            t
        })
        .clone()
}

/// The commit checked out (`git rev-parse`), with `+ uncommitted changes` when
/// the tracked files differ from it (but this file and [`DOCUMENTS`], which a
/// bless writes); `unknown` without git.
fn commit() -> String {
    let git = |args: &[&str]| {
        Command::new("git")
            .arg("-C")
            .arg(root())
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
    };
    let Some(head) = git(&["rev-parse", "--short=12", "HEAD"]) else {
        return "unknown".to_owned();
    };
    let mut args = vec![
        "status".to_owned(),
        "--porcelain".to_owned(),
        "--untracked-files=no".to_owned(),
        "--".to_owned(),
        ".".to_owned(),
    ];
    args.extend(
        std::iter::once(FILE)
            .chain(DOCUMENTS.iter().copied())
            .map(|f| format!(":(exclude){f}")),
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    match git(&args) {
        Some(changes) if changes.is_empty() => head,
        _ => format!("{head} + uncommitted changes"),
    }
}

/// Today's date (UTC), `YYYY-MM-DD`.
fn today() -> String {
    let days = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400);
    let (y, m, d) = civil_from_days(i64::try_from(days).unwrap_or(0));
    format!("{y:04}-{m:02}-{d:02}")
}

/// The proleptic Gregorian date of `days` since 1970-01-01 (H. Hinnant's
/// `civil_from_days`).
pub fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

/// The file's header.
const HEADER: &str = "\
# @generated by `cargo xtask bless` (the HIL tests with DECOY_BLESS=1): do not edit.
#
# What the HIL tests measured, per board (the names of firmware/boards.toml) and
# per thing measured; each entry's `measured` says when, at which commit and with
# which command. The tests hold every measurement to its budget (a hard limit:
# crates/decoy-hil/src/budgets.rs) and to its baseline here (a ratchet: worse
# fails, much better asks for a bless); crates/hil-tests/tests/common/baselines.rs
# says how. The docs quote this file through tables generated from it
# (crates/hil-tests/tests/baselines.rs).
";

/// The file's text for `root`: the header, then one `[section.key]` table per
/// entry, sections in [`SECTIONS`]' order, boards in the table's order, the
/// stamp first in each entry, flights and manoeuvres as one inline table a line.
pub fn render(root: &Table) -> String {
    let mut out = String::from(HEADER);
    for (section, value) in ordered(root, |k| {
        SECTIONS
            .iter()
            .position(|s| *s == k)
            .unwrap_or(SECTIONS.len())
    }) {
        let Some(table) = value.as_table() else {
            continue;
        };
        // A section of entries per board, or an entry itself.
        let per_board = table.keys().any(|k| Board::by_name(k).is_ok());
        if per_board {
            for (board, entry) in ordered(table, |k| {
                Board::by_name(k).map_or(usize::MAX, Board::index)
            }) {
                if let Some(entry) = entry.as_table() {
                    write_entry(&mut out, &[section, board], entry);
                }
            }
        } else {
            write_entry(&mut out, &[section], table);
        }
    }
    out
}

/// `table`'s entries ordered by `rank`, then by key.
fn ordered(table: &Table, rank: impl Fn(&str) -> usize) -> Vec<(&str, &Value)> {
    let mut entries: Vec<(&str, &Value)> = table.iter().map(|(k, v)| (k.as_str(), v)).collect();
    entries.sort_by(|a, b| rank(a.0).cmp(&rank(b.0)).then(a.0.cmp(b.0)));
    entries
}

fn write_entry(out: &mut String, path: &[&str], entry: &Table) {
    let _ = writeln!(out, "\n[{}]", dotted(path));
    for (k, v) in ordered(entry, |k| usize::from(k != MEASURED)) {
        let _ = writeln!(out, "{} = {}", key(k), value(v));
    }
}

/// A key as TOML writes it: bare when it can be, else quoted.
pub fn key(k: &str) -> String {
    let bare = !k.is_empty()
        && k.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare {
        k.to_owned()
    } else {
        Value::String(k.to_owned()).to_string()
    }
}

/// A value on one line: scalars as TOML writes them, tables inline.
fn value(v: &Value) -> String {
    match v {
        Value::Table(t) => {
            let fields: Vec<String> = t
                .iter()
                .map(|(k, v)| format!("{} = {}", key(k), value(v)))
                .collect();
            format!("{{ {} }}", fields.join(", "))
        }
        Value::Array(a) => {
            let items: Vec<String> = a.iter().map(value).collect();
            format!("[{}]", items.join(", "))
        }
        Value::Float(f) => format!("{f:?}"),
        other => other.to_string(),
    }
}

/// `x` rounded to `digits` decimals, for a value of the file that is not an
/// exact count (a mean, a relative error).
pub fn rounded(x: f64, digits: i32) -> Value {
    let scale = 10f64.powi(digits);
    Value::Float((x * scale).round() / scale)
}

/// A shipped manoeuvre's key in the file (`pull-up 0.20 rad/s`, `steady`):
/// its kind's name and its rate, if it has one.
pub fn manoeuvre_key(name: &str, rate: Option<f64>) -> String {
    match rate {
        Some(w) => format!("{name} {w:.2} rad/s"),
        None => name.to_owned(),
    }
}

/// The keys of every shipped manoeuvre (`decoy_hil::flight::SHIPPED_MANOEUVRES`).
pub fn shipped_keys() -> Vec<String> {
    decoy_hil::flight::SHIPPED_MANOEUVRES
        .iter()
        .map(|(kind, rate, _)| manoeuvre_key(kind.name(), *rate))
        .collect()
}

/// A count as a value of the file.
pub fn int(n: impl Into<u64>) -> Value {
    Value::Integer(i64::try_from(n.into()).unwrap_or(i64::MAX))
}
