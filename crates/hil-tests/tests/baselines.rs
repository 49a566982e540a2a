//! The measured baselines' file (`crates/hil-tests/baselines.toml`) and the
//! documents that quote it (no QEMU: this takes well under a second).
//!
//! - **The file** is as `cargo xtask bless` writes it (no hand edit), names
//!   only boards of `firmware/boards.toml`, flights of the envelope sweep's
//!   test grid and shipped manoeuvres, and has every board's entries (a board
//!   added to the table gets them by blessing), on the f32 boards every flight
//!   of the grid.
//! - **The documents' tables** between `<!-- baselines: ID -->` and `<!-- end
//!   baselines -->` (README.md, firmware/README.md) are what this test renders
//!   from the file and from the budgets (`decoy_hil::budgets`); with
//!   `DECOY_BLESS=1` (the last step of `cargo xtask bless`) it rewrites them
//!   instead. The documents cite the file and these tables, never copies of
//!   the numbers.

mod common;

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::sync::OnceLock;

use common::baselines::{self, DOCUMENTS, FILE, MEASURED, SECTIONS, number, table_at};
use decoy_config::SystemConfig;
use decoy_hil::budgets::{self, Budget};
use decoy_hil::qemu::{Board, Precision};
use decoy_hil::sweep::{self, Grid, Group};
use toml::{Table, Value};

/// The marker's kind: `<!-- baselines: ID -->`.
const KIND: &str = "baselines";

fn config() -> &'static SystemConfig {
    static CONFIG: OnceLock<SystemConfig> = OnceLock::new();
    CONFIG.get_or_init(|| SystemConfig::builtin().expect("the built-in configuration"))
}

/// The sections whose entries are per board.
const PER_BOARD: &[&str] = &["step_cost", "memory", "panic_sites", "envelope"];

/// The entry of `board` in `section`.
fn entry(section: &str, board: Board) -> Option<&'static Table> {
    table_at(baselines::file(), &[section, board.name()])
}

/// The entries of `section` for `board` that are tables (flights, manoeuvres),
/// by name.
fn lines(table: Option<&'static Table>) -> Vec<(&'static str, &'static Table)> {
    table
        .map(|t| {
            t.iter()
                .filter(|(k, _)| k.as_str() != MEASURED)
                .filter_map(|(k, v)| Some((k.as_str(), v.as_table()?)))
                .collect()
        })
        .unwrap_or_default()
}

/// A field of an entry as a number.
fn field(t: &Table, name: &str) -> Option<f64> {
    t.get(name).and_then(number)
}

/// A count with thousands separators (`88,960`).
fn thousands(x: f64) -> String {
    let digits = format!("{:.0}", x.abs());
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    if x < 0.0 { format!("-{out}") } else { out }
}

/// A count, or a dash when there is none.
fn count(x: Option<f64>) -> String {
    x.map_or_else(|| "-".to_owned(), thousands)
}

/// A relative error as a signed percentage (`+0.47 %`; three decimals where
/// two would show none).
fn percent(x: Option<f64>) -> String {
    x.map_or_else(
        || "-".to_owned(),
        |x| {
            if (100.0 * x).abs() < 0.005 {
                format!("{:+.3} %", 100.0 * x)
            } else {
                format!("{:+.2} %", 100.0 * x)
            }
        },
    )
}

/// A table's separator: a left-aligned first column, `n` right-aligned.
fn separator(n: usize) -> String {
    format!("|---|{}", "---:|".repeat(n))
}

/// The board columns' header cells.
fn board_columns(suffix: &str) -> String {
    Board::all()
        .iter()
        .map(|b| format!(" {}{suffix} |", b.label()))
        .collect()
}

/// "(`FILE`, measured DATE at COMMIT: `cargo xtask bless` ...)" for the entries
/// at `paths`.
fn source(paths: &[Vec<&str>]) -> String {
    let mut when = BTreeSet::new();
    for path in paths {
        if let Some(stamp) = table_at(baselines::file(), path)
            .and_then(|t| t.get(MEASURED))
            .and_then(Value::as_table)
        {
            let s = |k: &str| stamp.get(k).and_then(Value::as_str).unwrap_or("?");
            when.insert(format!("{} at {}", s("date"), s("commit")));
        }
    }
    let when: Vec<String> = when.into_iter().collect();
    format!(
        "\n(From `{FILE}`, measured {}; `{}` refreshes it and this table.)\n",
        if when.is_empty() {
            "never".to_owned()
        } else {
            when.join(", ")
        },
        baselines::BLESS
    )
}

/// The paths of every board's entry of `section`.
fn per_board(section: &str) -> Vec<Vec<&str>> {
    Board::all()
        .iter()
        .map(|b| vec![section, b.name()])
        .collect()
}

/// A budget per board as a cell: its limit with `unit`, or a dash.
fn budget_row<T: Copy>(
    what: &str,
    of: impl Fn(Board) -> Option<Budget<T>>,
    show: impl Fn(T) -> String,
) -> String {
    let mut row = format!("| {what} |");
    let mut sources = BTreeSet::new();
    for &board in Board::all() {
        match of(board) {
            Some(b) => {
                let _ = write!(row, " {} |", show(b.limit));
                sources.insert(b.source);
            }
            None => row.push_str(" - |"),
        }
    }
    let sources: Vec<&str> = sources.into_iter().collect();
    let _ = writeln!(row, " {} |", sources.join("; "));
    row
}

/// The budgets (`decoy_hil::budgets`), per board.
fn budgets_table() -> String {
    let mut s = format!(
        "| budget (a hard limit) |{} from |\n{}---|\n",
        board_columns(""),
        separator(Board::all().len())
    );
    let int = |x: u32| thousands(f64::from(x));
    s += &budget_row(
        "instructions of a 10 ms frame over the envelope, the trim's frames included",
        |b| Some(budgets::frame(b)),
        int,
    );
    s += &budget_row(
        "instructions of one RK4 step (four stages)",
        budgets::rk4_step,
        int,
    );
    s += &budget_row(
        "instructions of decoy management in a frame",
        |_| Some(budgets::MANAGEMENT),
        int,
    );
    s += &budget_row(
        "RAM at the peak (static RAM and the deepest stack), bytes",
        |b| Some(budgets::ram_peak(b)),
        |x: u64| thousands(x as f64),
    );
    s += &budget_row(
        "peak connection tension against 300 segments in f64, same frames (the f32 controller, host)",
        |b| (b.precision() == Precision::F32).then_some(budgets::PEAK_TENSION),
        |x: f64| format!("{:.0} %", 100.0 * x),
    );
    s.push_str("\n(From `crates/decoy-hil/src/budgets.rs` and `firmware/boards.toml`.)\n");
    s
}

/// Over the flights of `board`'s envelope entry in `group` (all if `None`):
/// the worst of `name` and the flight it is in; the lowest and highest mean.
fn envelope_worst(
    board: Board,
    group: Option<Group>,
    name: &str,
) -> Option<(f64, &'static str, f64, f64)> {
    let mut worst: Option<(f64, &str)> = None;
    let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
    for (label, t) in lines(entry("envelope", board)) {
        if group.is_some_and(|g| t.get("group").and_then(Value::as_str) != Some(g.name())) {
            continue;
        }
        let (Some(x), Some(mean)) = (field(t, name), field(t, "mean")) else {
            continue;
        };
        if worst.is_none_or(|(w, _)| x > w) {
            worst = Some((x, label));
        }
        low = low.min(mean);
        high = high.max(mean);
    }
    worst.map(|(w, label)| (w, label, low, high))
}

/// The summary per board: the worst frame over the envelope, the trim's, the
/// RK4 step and the RAM peak, each against its budget.
fn summary_table() -> String {
    let mut s = "| board | scalar | worst frame over the envelope | mean frames | worst frame of \
                 the trim | one RK4 step | RAM peak, bytes |\n|---|---|---:|---:|---:|---:|---:|\n"
        .to_owned();
    for &board in Board::all() {
        let worst = envelope_worst(board, None, "worst");
        let trim = envelope_worst(board, None, "trim_worst");
        let step = entry("step_cost", board).and_then(|t| field(t, "four_stages"));
        let ram = entry("memory", board).and_then(|t| field(t, "ram_peak"));
        let of = |x: Option<f64>, limit: Option<f64>| match (x, limit) {
            (Some(x), Some(l)) => format!("{} of {}", thousands(x), thousands(l)),
            (x, _) => count(x),
        };
        let frame = f64::from(budgets::frame(board).limit);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            board.label(),
            board.precision(),
            worst.map_or_else(
                || "-".to_owned(),
                |(w, label, ..)| format!("**{}** of {} ({label})", thousands(w), thousands(frame))
            ),
            worst.map_or_else(
                || "-".to_owned(),
                |(.., low, high)| format!("{} to {}", thousands(low), thousands(high))
            ),
            of(trim.map(|t| t.0), Some(frame)),
            of(step, budgets::rk4_step(board).map(|b| f64::from(b.limit))),
            of(ram, Some(budgets::ram_peak(board).limit as f64)),
        );
    }
    let mut paths = per_board("envelope");
    paths.extend(per_board("step_cost"));
    paths.extend(per_board("memory"));
    s + &source(&paths)
}

/// The envelope per group of flights and board: the worst control step (and
/// its flight), the means' range; the trim's frames; the management.
fn envelope_table() -> String {
    let mut s = format!(
        "| group (test grid) |{}\n{}\n",
        board_columns(""),
        separator(Board::all().len())
    );
    let groups = [
        Group::Steady,
        Group::Shipped,
        Group::RateLimit,
        Group::Tropopause,
    ];
    let row = |title: &str, group: Option<Group>, name: &str, means: bool| {
        let mut r = format!("| {title} |");
        for &board in Board::all() {
            let flights = lines(entry("envelope", board))
                .iter()
                .filter(|(_, t)| {
                    group.is_none_or(|g| t.get("group").and_then(Value::as_str) == Some(g.name()))
                })
                .count();
            let cell = match envelope_worst(board, group, name) {
                Some((w, label, low, high)) if means => format!(
                    "**{}** ({label}); mean {} to {}; {flights} flight{}",
                    thousands(w),
                    thousands(low),
                    thousands(high),
                    if flights == 1 { "" } else { "s" }
                ),
                Some((w, label, ..)) => format!("**{}** ({label})", thousands(w)),
                None => "-".to_owned(),
            };
            let _ = write!(r, " {cell} |");
        }
        r + "\n"
    };
    for g in groups {
        s += &row(g.name(), Some(g), "worst", true);
    }
    s += &row("the trim's frames", None, "trim_worst", false);
    s += &row(
        "decoy management in a frame (after the answer)",
        None,
        "management",
        false,
    );
    s + &source(&per_board("envelope"))
}

/// The shipped manoeuvres at their full duration on each board: worst and
/// mean frame; on the f32 boards the differences from the host's f64.
fn shipped_table() -> String {
    let boards = Board::all();
    let mut s = format!(
        "| manoeuvre |{} f32 against the host's f64: largest difference at the connection / at the towing point; the peaks |\n{}---|\n",
        board_columns(" worst / mean"),
        separator(boards.len())
    );
    let f32_board = boards
        .iter()
        .copied()
        .find(|b| b.precision() == Precision::F32);
    let shipped: Vec<&str> = f32_board
        .map(|b| {
            lines(entry("envelope", b))
                .into_iter()
                .filter(|(_, t)| t.get("group").and_then(Value::as_str) == Some("shipped"))
                .map(|(label, _)| label)
                .collect()
        })
        .unwrap_or_default();
    for label in shipped {
        let _ = write!(s, "| {label} |");
        for &board in boards {
            let t = lines(entry("envelope", board))
                .into_iter()
                .find(|(l, _)| *l == label)
                .map(|(_, t)| t);
            let cell = t.map_or_else(
                || "-".to_owned(),
                |t| format!("{} / {}", count(field(t, "worst")), count(field(t, "mean"))),
            );
            let _ = write!(s, " {cell} |");
        }
        let f64_cell = f32_board
            .and_then(|b| {
                lines(entry("envelope", b))
                    .into_iter()
                    .find(|(l, _)| *l == label)
            })
            .map_or_else(
                || "-".to_owned(),
                |(_, t)| {
                    let p = |k| {
                        field(t, k)
                            .map_or_else(|| "-".to_owned(), |x| format!("{:.2} %", 100.0 * x))
                    };
                    format!(
                        "{} / {} / {}",
                        p("f64_connection"),
                        p("f64_tow"),
                        p("f64_peak")
                    )
                },
            );
        let _ = writeln!(s, " {f64_cell} |");
    }
    s + &source(&per_board("envelope"))
}

/// One RK4 step per board.
fn step_table() -> String {
    let mut s = "| board | scalar | RK4 step, all four stages evaluated | its spread over the \
                 steady turn | first step of a frame (first stage reused) | output evaluation | \
                 flight path of a frame |\n|---|---|---:|---:|---:|---:|---:|\n"
        .to_owned();
    for &board in Board::all() {
        let t = entry("step_cost", board);
        let f = |k: &str| count(t.and_then(|t| field(t, k)));
        let budget = budgets::rk4_step(board).map_or_else(String::new, |b| {
            format!(" of {}", thousands(f64::from(b.limit)))
        });
        let _ = writeln!(
            s,
            "| {} | {} | **{}**{budget} | {} | {} | {} | {} |",
            board.label(),
            board.precision(),
            f("four_stages"),
            f("spread"),
            f("first_stage_reused"),
            f("outputs"),
            f("path"),
        );
    }
    s + &source(&per_board("step_cost"))
}

/// Memory per board.
fn memory_table() -> String {
    let mut s = "| board | scalar | flash (.text + .data) | static RAM (.data + .bss) | \
                 controller (in .bss) | stack, boot | stack, link loop | RAM peak | of its RAM \
                 |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n"
        .to_owned();
    for &board in Board::all() {
        let t = entry("memory", board);
        let f = |k: &str| t.and_then(|t| field(t, k));
        let share = f("ram_peak").map_or_else(
            || "-".to_owned(),
            |peak| {
                let ram = board.ram_budget() as f64;
                format!(
                    "{:.0} % of {} ({} left)",
                    100.0 * peak / ram,
                    thousands(ram),
                    thousands(ram - peak)
                )
            },
        );
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | **{}** | {share} |",
            board.label(),
            board.precision(),
            count(f("flash")),
            count(f("static_ram")),
            count(f("controller")),
            count(f("stack_boot")),
            count(f("stack_link")),
            count(f("ram_peak")),
        );
    }
    s + &source(&per_board("memory"))
}

/// The accuracy per shipped manoeuvre (host).
fn accuracy_table() -> String {
    let mut s = "| manoeuvre | f32 controller against 300 segments f64: same frames | on the \
                 analytic path | embedded model, converged steps, same frames | peak: controller \
                 / 300 segments, same frames / analytic path, N |\n|---|---:|---:|---:|---:|\n"
        .to_owned();
    let section = table_at(baselines::file(), &["host_accuracy"]);
    for key in baselines::shipped_keys() {
        let t = section.and_then(|t| t.get(&key)).and_then(Value::as_table);
        let f = |k: &str| t.and_then(|t| field(t, k));
        let n = |k: &str| f(k).map_or_else(|| "-".to_owned(), |x| format!("{x:.1}"));
        let _ = writeln!(
            s,
            "| {key} | {} | {} | {} | {} / {} / {} |",
            percent(f("same_frames")),
            percent(f("analytic")),
            percent(f("embedded_converged")),
            n("controller_n"),
            n("same_frames_n"),
            n("analytic_n"),
        );
    }
    s + &source(&[vec!["host_accuracy"]])
}

/// The panic branches left per function and board.
fn panic_table() -> String {
    let mut functions = BTreeSet::new();
    for &board in Board::all() {
        if let Some(t) = entry("panic_sites", board) {
            functions.extend(t.keys().filter(|k| k.as_str() != MEASURED));
        }
    }
    let mut s = format!(
        "| function |{}\n{}\n",
        board_columns(""),
        separator(Board::all().len())
    );
    for function in functions {
        let _ = write!(s, "| `{function}` |");
        for &board in Board::all() {
            let n = entry("panic_sites", board).and_then(|t| field(t, function));
            let _ = write!(s, " {} |", count(n));
        }
        s.push('\n');
    }
    s + &source(&per_board("panic_sites"))
}

/// The table `id` renders.
fn table(id: &str) -> String {
    match id {
        "budgets" => budgets_table(),
        "summary" => summary_table(),
        "envelope" => envelope_table(),
        "shipped" => shipped_table(),
        "step" => step_table(),
        "memory" => memory_table(),
        "accuracy" => accuracy_table(),
        "panic" => panic_table(),
        _ => panic!(
            "no generated table `{id}` (the IDs: budgets, summary, envelope, shipped, step, memory, accuracy, panic)"
        ),
    }
}

/// `text` with every generated part (after a line `<!-- baselines: ID -->`, up
/// to `<!-- end baselines -->`) replaced by `table(ID)`; and the IDs met.
fn regenerate(text: &str) -> (String, Vec<String>) {
    let end = format!("<!-- end {KIND} -->");
    let mut out = String::new();
    let mut seen = Vec::new();
    let mut lines = text.split_inclusive('\n');
    while let Some(line) = lines.next() {
        out.push_str(line);
        let Some(id) = line
            .trim()
            .strip_prefix("<!-- ")
            .and_then(|l| l.strip_suffix(" -->"))
            .and_then(|l| l.strip_prefix(KIND))
            .and_then(|l| l.strip_prefix(": "))
        else {
            continue;
        };
        out.push_str(&table(id));
        seen.push(id.to_owned());
        let mut closed = false;
        for skipped in lines.by_ref() {
            if skipped.trim() == end {
                out.push_str(skipped);
                closed = true;
                break;
            }
        }
        assert!(closed, "a `<!-- {KIND}: {id} -->` part has no `{end}`");
    }
    (out, seen)
}

/// Every document's generated tables are current (with `DECOY_BLESS`,
/// rewritten).
#[test]
fn the_documents_quote_the_baselines() {
    let mut stale = Vec::new();
    let mut seen = BTreeSet::new();
    for document in DOCUMENTS {
        let path = baselines::root().join(document);
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{document}: {e}"));
        let (expected, ids) = regenerate(&text);
        seen.extend(ids);
        if expected == text {
            continue;
        }
        if baselines::blessing() {
            std::fs::write(&path, &expected).unwrap_or_else(|e| panic!("{document}: {e}"));
            continue;
        }
        let differs = text
            .lines()
            .zip(expected.lines())
            .find(|(a, b)| a != b)
            .map_or_else(String::new, |(a, b)| {
                format!("\n  {document}: {a}\n  generated: {b}")
            });
        stale.push(format!("{document}{differs}"));
    }
    assert!(
        stale.is_empty(),
        "generated tables differ from {FILE} (rewrite them with `DECOY_BLESS=1 cargo test -p \
         hil-tests --test baselines`, the last step of `cargo xtask bless`):\n{}",
        stale.join("\n")
    );
    for id in [
        "budgets", "summary", "envelope", "step", "memory", "accuracy",
    ] {
        assert!(seen.contains(id), "no document shows the table `{id}`");
    }
}

/// The file is as `cargo xtask bless` writes it, names only what exists, and
/// has every board's entries.
#[test]
fn the_file_is_generated_and_complete() {
    let file = baselines::file();
    let text = std::fs::read_to_string(baselines::path()).unwrap_or_else(|e| panic!("{FILE}: {e}"));
    assert!(
        text == baselines::render(file),
        "{FILE} is not as `{}` writes it: edited by hand?",
        baselines::BLESS
    );
    for section in file.keys() {
        assert!(
            SECTIONS.contains(&section.as_str()),
            "{FILE}: unknown section `{section}` (the sections: {SECTIONS:?})"
        );
    }
    for section in PER_BOARD {
        let table = table_at(file, &[section]);
        for key in table
            .map(|t| t.keys().collect::<Vec<_>>())
            .unwrap_or_default()
        {
            assert!(
                Board::by_name(key).is_ok(),
                "{FILE}: `{section}.{key}` names no board of firmware/boards.toml (run `{}`)",
                baselines::BLESS
            );
        }
        for &board in Board::all() {
            assert!(
                entry(section, board).is_some(),
                "{FILE}: no `{section}.{board}` (run `{}` to measure the board)",
                baselines::BLESS
            );
        }
    }
    let grid: Vec<String> = sweep::cases(config(), Grid::Test)
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .map(|c| c.label)
        .collect();
    for &board in Board::all() {
        let flown = lines(entry("envelope", board));
        for (label, _) in &flown {
            assert!(
                grid.iter().any(|g| g == label),
                "{FILE}: `envelope.{board}` has `{label}`, no flight of the test grid (run `{}`)",
                baselines::BLESS
            );
        }
        // The f32 boards fly the whole grid (the f64 boards a subset): their
        // baselines are the whole grid's, never a shortened run's.
        if board.precision() == Precision::F32 {
            for label in &grid {
                assert!(
                    flown.iter().any(|(l, _)| l == label),
                    "{FILE}: `envelope.{board}` has no `{label}` (run `{}` over the whole grid)",
                    baselines::BLESS
                );
            }
        }
    }
    let shipped = baselines::shipped_keys();
    let accuracy = lines(table_at(file, &["host_accuracy"]));
    for (key, _) in &accuracy {
        assert!(
            shipped.iter().any(|s| s == key),
            "{FILE}: `host_accuracy` has `{key}`, no shipped manoeuvre"
        );
    }
    assert_eq!(
        accuracy.len(),
        shipped.len(),
        "{FILE}: `host_accuracy` has {} of the {} shipped manoeuvres (run `{}`)",
        accuracy.len(),
        shipped.len(),
        baselines::BLESS
    );
}

#[test]
fn dates_and_numbers_as_the_tables_show_them() {
    assert_eq!(baselines::civil_from_days(0), (1970, 1, 1));
    assert_eq!(baselines::civil_from_days(19_723), (2024, 1, 1));
    assert_eq!(baselines::civil_from_days(19_782), (2024, 2, 29));
    assert_eq!(thousands(88_960.0), "88,960");
    assert_eq!(thousands(960.0), "960");
    assert_eq!(thousands(1_221_080.0), "1,221,080");
    assert_eq!(percent(Some(-0.0176)), "-1.76 %");
    assert_eq!(
        baselines::key("pull-up 0.20 rad/s"),
        "\"pull-up 0.20 rad/s\""
    );
    assert_eq!(baselines::key("m4"), "m4");
}
