//! The generated parts of the documents: docs/outputs.md's column tables
//! (between `<!-- columns: ID -->` and `<!-- end columns -->`, one per
//! [`crate::CSV_FILES`] entry) and docs/management.md's requirement table
//! (between `<!-- requirements -->` and `<!-- end requirements -->`) are what the
//! schema writes; with `DECOY_BLESS=1` the test rewrites them instead.

extern crate std;
use std::path::PathBuf;
use std::string::{String, ToString};
use std::vec::Vec;

use crate::{CSV_FILES, Requirement};

/// The end marker of a generated part.
fn end_marker(kind: &str) -> String {
    std::format!("<!-- end {kind} -->")
}

/// `text` with every generated part (after a line `<!-- KIND -->` or `<!--
/// KIND: ID -->`) replaced by `table(ID)`; and the IDs met.
fn regenerate(text: &str, kind: &str, table: impl Fn(&str) -> String) -> (String, Vec<String>) {
    let mut out = String::new();
    let mut seen = Vec::new();
    let end = end_marker(kind);
    let mut lines = text.split_inclusive('\n');
    while let Some(line) = lines.next() {
        out.push_str(line);
        let Some(rest) = line
            .trim()
            .strip_prefix("<!-- ")
            .and_then(|l| l.strip_suffix(" -->"))
            .and_then(|l| l.strip_prefix(kind))
        else {
            continue;
        };
        let id = rest.strip_prefix(": ").unwrap_or(rest).to_string();
        out.push_str(&table(&id));
        seen.push(id);
        let mut closed = false;
        for skipped in lines.by_ref() {
            if skipped.trim() == end {
                out.push_str(skipped);
                closed = true;
                break;
            }
        }
        assert!(closed, "a `<!-- {kind} -->` part has no `{end}`");
    }
    (out, seen)
}

/// Checks (or, with `DECOY_BLESS`, rewrites) the generated parts of `file`
/// (relative to the repository's root).
fn check(file: &str, kind: &str, ids: &[&str], table: impl Fn(&str) -> String) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(file);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
    let (expected, seen) = regenerate(&text, kind, table);
    let missing: Vec<&&str> = ids
        .iter()
        .filter(|id| !seen.iter().any(|s| s == *id))
        .collect();
    assert!(
        missing.is_empty(),
        "{file} has no generated part for {missing:?}: add `<!-- {kind}: ID -->` (or `<!-- {kind} -->`) and `{}` where it belongs",
        end_marker(kind)
    );
    if std::env::var_os("DECOY_BLESS").is_some() {
        if expected != text {
            std::fs::write(&path, &expected).unwrap_or_else(|e| panic!("{file}: {e}"));
        }
        return;
    }
    if expected != text {
        let differs = text
            .lines()
            .zip(expected.lines())
            .find(|(a, b)| a != b)
            .map_or_else(String::new, |(a, b)| {
                std::format!("\n  {file}: {a}\n  schema: {b}")
            });
        panic!(
            "{file}'s generated tables differ from decoy-schema's (rewrite them with `DECOY_BLESS=1 cargo test -p decoy-schema`):{differs}"
        );
    }
}

#[test]
fn docs_outputs_md_shows_every_column_table() {
    let ids: Vec<&str> = CSV_FILES.iter().map(|f| f.id).collect();
    check("docs/outputs.md", "columns", &ids, |id| {
        CSV_FILES
            .iter()
            .find(|f| f.id == id)
            .unwrap_or_else(|| panic!("docs/outputs.md: no file `{id}` in the schema"))
            .markdown_table()
            .to_string()
    });
}

/// docs/outputs.md quotes the recorded flights' header line as it is.
#[test]
fn docs_outputs_md_quotes_the_recorded_flight_header() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/outputs.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let header = std::format!("\n{}\n", crate::columns::RECORDED_FLIGHT.header());
    assert!(
        text.contains(&header),
        "docs/outputs.md does not quote the recorded flights' header{header}"
    );
}

#[test]
fn docs_management_md_shows_the_requirement_table() {
    check("docs/management.md", "requirements", &[""], |_| {
        Requirement::markdown_table().to_string()
    });
}
