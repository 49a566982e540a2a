//! Loading: the built-in systems, files, text, and overlays.
//!
//! The overlay rules are the crate's documentation ("Overlays"): the files
//! of a chain are read base first into one buffer, so that a span in the
//! merged tables tells the file and the line it came from.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

use crate::error::{ConfigError, toml_error};
use crate::limits::LimitsFile;
use crate::schema::SystemConfig;
use crate::tables::parse_aero_csv;
use crate::validation::Origins;

/// The built-in system description (`config/reference-system.toml`).
pub const BUILTIN_TOML: &str = include_str!("../../../config/reference-system.toml");
/// The built-in decoy aerodynamic table (`config/decoy-aero.csv`).
pub const BUILTIN_AERO_CSV: &str = include_str!("../../../config/decoy-aero.csv");
/// The built-in weak-stability decoy (`config/weak-stability-decoy.toml`): an
/// overlay on the reference system.
pub const WEAK_STABILITY_TOML: &str = include_str!("../../../config/weak-stability-decoy.toml");
/// The built-in reference system's envelope map on board
/// (`config/reference-system.limits.toml`).
pub const BUILTIN_LIMITS_TOML: &str = include_str!("../../../config/reference-system.limits.toml");
/// How errors in the built-in TOML name their file.
pub const BUILTIN_TOML_NAME: &str = "built-in reference-system.toml";
/// How errors in the built-in aerodynamic table name their file.
pub const BUILTIN_AERO_NAME: &str = "built-in decoy-aero.csv";
/// How the built-in weak-stability decoy names itself.
pub const WEAK_STABILITY_NAME: &str = "built-in weak-stability-decoy.toml";
/// The key of an overlay that names its base.
pub const BASE_KEY: &str = "base";

/// The built-in files by the names their `base` and `decoy.aero_table` keys use
/// (their names in `config/`).
const BUILTIN_FILES: [(&str, &str); 4] = [
    ("reference-system.toml", BUILTIN_TOML),
    ("weak-stability-decoy.toml", WEAK_STABILITY_TOML),
    ("decoy-aero.csv", BUILTIN_AERO_CSV),
    ("reference-system.limits.toml", BUILTIN_LIMITS_TOML),
];

impl SystemConfig {
    /// The project's reference system, embedded in the binary.
    pub fn builtin() -> Result<Self, ConfigError> {
        load(builtin_file("reference-system.toml")?, MapPolicy::Check)
    }

    /// The reference system without its envelope map on board (not read, so
    /// not checked): what the map is made from (`decoy envelope`, `decoy
    /// limits-table`), which must load while the map is stale.
    pub fn builtin_unmapped() -> Result<Self, ConfigError> {
        load(builtin_file("reference-system.toml")?, MapPolicy::Skip)
    }

    /// [`SystemConfig::from_file`] without the envelope map on board (see
    /// [`SystemConfig::builtin_unmapped`]).
    pub fn from_file_unmapped(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        load(disk_file(path.as_ref())?, MapPolicy::Skip)
    }

    /// The reference system as `decoy envelope` loads it: its envelope map on
    /// board used when it is there, readable and made for it (the onboard
    /// controller flown beside the map's runs then advises with it, as the
    /// firmware's does), and otherwise left, never an error (the map is what
    /// `decoy envelope` makes).
    pub fn builtin_for_mapping() -> Result<Self, ConfigError> {
        load(builtin_file("reference-system.toml")?, MapPolicy::IfFresh)
    }

    /// [`SystemConfig::from_file`] as `decoy envelope` loads it (see
    /// [`SystemConfig::builtin_for_mapping`]).
    pub fn from_file_for_mapping(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        load(disk_file(path.as_ref())?, MapPolicy::IfFresh)
    }

    /// The second decoy, built in: `config/weak-stability-decoy.toml`, an overlay
    /// on the reference system that moves the decoy's moment reference point and
    /// towing point (a weakly stable decoy; the file says why).
    pub fn weak_stability() -> Result<Self, ConfigError> {
        load(builtin_file("weak-stability-decoy.toml")?, MapPolicy::Check)
    }

    /// Loads a system TOML file: a whole system, or an overlay on a `base`
    /// resolved relative to the file's directory; `decoy.aero_table` is resolved
    /// relative to the directory of the file that names it (or used as is when
    /// absolute).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        load(disk_file(path.as_ref())?, MapPolicy::Check)
    }

    /// Parses a system from TOML text and the text of its aerodynamic table (the
    /// TOML's `decoy.aero_table` is then only a name used in messages). The text
    /// cannot be an overlay: without a file there is nothing to resolve `base`
    /// against, nor `envelope.limits_map` (the system has no envelope map on
    /// board).
    pub fn from_str(toml_text: &str, aero_csv_text: &str) -> Result<Self, ConfigError> {
        load(
            File {
                name: "configuration".to_owned(),
                identity: String::new(),
                place: Place::Text {
                    aero_csv: aero_csv_text.to_owned(),
                },
                text: toml_text.to_owned(),
            },
            MapPolicy::Check,
        )
    }

    /// Parses a system from the TOML text of a file that is not on disk (a
    /// Python dict's, in the `decoy` Python package), named `name` in messages.
    /// Its `base` and `decoy.aero_table` resolve as a file's in `dir` would; a
    /// name that is no file there but one of the built-in files
    /// (`reference-system.toml`, `weak-stability-decoy.toml`, `decoy-aero.csv`)
    /// is the built-in file, so that `base = "reference-system.toml"` is an
    /// overlay on the built-in reference system from any directory. Validated
    /// as a file is, with the same errors.
    pub fn from_text_in(name: &str, toml_text: &str, dir: &Path) -> Result<Self, ConfigError> {
        load(File::given(name, toml_text, dir), MapPolicy::Check)
    }

    /// [`SystemConfig::from_text_in`] without the envelope map on board (see
    /// [`SystemConfig::builtin_unmapped`]).
    pub fn from_text_in_unmapped(
        name: &str,
        toml_text: &str,
        dir: &Path,
    ) -> Result<Self, ConfigError> {
        load(File::given(name, toml_text, dir), MapPolicy::Skip)
    }

    /// [`SystemConfig::from_text_in`] as `decoy envelope` loads it (see
    /// [`SystemConfig::builtin_for_mapping`]).
    pub fn from_text_in_for_mapping(
        name: &str,
        toml_text: &str,
        dir: &Path,
    ) -> Result<Self, ConfigError> {
        load(File::given(name, toml_text, dir), MapPolicy::IfFresh)
    }
}

/// Where a file was found: what the names it gives resolve against.
#[derive(Clone, Debug)]
enum Place {
    /// One of [`BUILTIN_FILES`]: names resolve among them.
    Builtin,
    /// A file on disk: names resolve against its directory.
    Disk(PathBuf),
    /// Text without a file whose names resolve against this directory, else
    /// among the built-in files ([`SystemConfig::from_text_in`]).
    Given(PathBuf),
    /// Text given with its aerodynamic table and without a file.
    Text {
        /// The aerodynamic table's text.
        aero_csv: String,
    },
}

/// One configuration file's text and where it came from.
#[derive(Clone, Debug)]
struct File {
    /// How messages name it.
    name: String,
    /// What makes two files the same one (cycles of `base`).
    identity: String,
    /// What its names resolve against.
    place: Place,
    /// Its text.
    text: String,
}

impl File {
    /// The text of a file that is not on disk, named `name`, whose names
    /// resolve in `dir` (else among the built-in files).
    fn given(name: &str, text: &str, dir: &Path) -> File {
        File {
            name: name.to_owned(),
            identity: name.to_owned(),
            place: Place::Given(dir.to_owned()),
            text: text.to_owned(),
        }
    }

    /// The file `relative` names from this one (its `base` or its aerodynamic
    /// table), or why it cannot be had.
    fn open(&self, field: &str, relative: &str) -> Result<File, ConfigError> {
        match &self.place {
            Place::Builtin => builtin_file(relative),
            Place::Disk(path) => {
                let dir = path.parent().unwrap_or_else(|| Path::new("."));
                disk_file(&tidy(&dir.join(relative)))
            }
            Place::Given(dir) => {
                let path = tidy(&dir.join(relative));
                if !path.exists() && builtin_file(relative).is_ok() {
                    builtin_file(relative)
                } else {
                    disk_file(&path)
                }
            }
            Place::Text { .. } => Err(ConfigError::Invalid {
                file: self.name.clone(),
                field: field.to_owned(),
                message: format!(
                    "= \"{relative}\" cannot be resolved in text given without its file \
                     (load the file with SystemConfig::from_file)"
                ),
            }),
        }
    }
}

/// The built-in file `name`.
fn builtin_file(name: &str) -> Result<File, ConfigError> {
    let name = name.strip_prefix("./").unwrap_or(name);
    let text = BUILTIN_FILES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, text)| *text)
        .ok_or_else(|| ConfigError::Io {
            path: PathBuf::from(name),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!(
                    "not a built-in file (those are {})",
                    BUILTIN_FILES.map(|(n, _)| n).join(", ")
                ),
            ),
        })?;
    Ok(File {
        name: format!("built-in {name}"),
        identity: format!("built-in {name}"),
        place: Place::Builtin,
        text: text.to_owned(),
    })
}

/// `path` without `.` components and with each `dir/..` pair removed (a
/// relative name joined to a directory reads as the file it names).
fn tidy(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut tidy = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir
                if matches!(tidy.components().next_back(), Some(Component::Normal(_))) =>
            {
                tidy.pop();
            }
            other => tidy.push(other),
        }
    }
    tidy
}

/// The file at `path`.
fn disk_file(path: &Path) -> Result<File, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
        path: path.to_owned(),
        source,
    })?;
    let identity = std::fs::canonicalize(path)
        .unwrap_or_else(|_| path.to_owned())
        .display()
        .to_string();
    Ok(File {
        name: path.display().to_string(),
        identity,
        place: Place::Disk(path.to_owned()),
        text,
    })
}

/// Whether loading reads the envelope map on board.
#[derive(Clone, Copy, PartialEq, Eq)]
enum MapPolicy {
    /// Read it and check it against the configuration's hash.
    Check,
    /// Leave it unread (`limits` None).
    Skip,
    /// Read it and use it if it is there, readable and made for the
    /// configuration; otherwise leave it (`limits` None), never an error.
    IfFresh,
}

/// Loads `top` with its chain of bases, merges, deserialises, validates and
/// reads the aerodynamic table and (by `policy`) the envelope map on board.
fn load(top: File, policy: MapPolicy) -> Result<SystemConfig, ConfigError> {
    let files = chain(top)?;
    // Every file's text in one buffer, base first, so that a span in the merged
    // tables tells which file (and line) it came from.
    let mut all = String::new();
    let mut starts = Vec::with_capacity(files.len());
    for file in &files {
        starts.push(all.len());
        all.push_str(&file.text);
        all.push('\n');
    }
    let file_at = |span: &Range<usize>| -> usize {
        starts
            .iter()
            .rposition(|&start| start <= span.start)
            .unwrap_or(0)
    };

    let mut merged = DeTable::new();
    let mut origins = BTreeMap::new();
    for (file, &start) in files.iter().zip(&starts) {
        let text = &all[start..start + file.text.len()];
        let mut table = DeTable::parse(text)
            .map_err(|e| toml_error(&file.name, &file.text, e.message(), e.span()))?
            .into_inner();
        table.remove(BASE_KEY);
        let table = shift_table(table, start);
        record_origins(&table, "", &file.name, &mut origins);
        merge(&mut merged, table);
    }
    let top = files.last().expect("the chain holds the file loaded");
    let deserializer = toml::de::Deserializer::from(Spanned::new(0..all.len(), merged));
    let mut config = SystemConfig::deserialize(deserializer).map_err(|e| match e.span() {
        Some(span) => {
            let i = file_at(&span);
            let local = span.start - starts[i]..span.end - starts[i];
            toml_error(&files[i].name, &files[i].text, e.message(), Some(local))
        }
        None => toml_error(&top.name, &top.text, e.message(), None),
    })?;
    config.source = top.name.clone();
    let origins = Origins::new(&top.name, origins);
    config.validate_with(&origins)?;

    let named_by = origins.file_of("decoy.aero_table");
    let owner = files.iter().find(|f| f.name == named_by).unwrap_or(top);
    let (csv_name, csv_text) = match &owner.place {
        Place::Text { aero_csv } => (config.decoy.aero_table.clone(), aero_csv.clone()),
        _ => {
            let csv = owner.open("decoy.aero_table", &config.decoy.aero_table)?;
            (csv.name, csv.text)
        }
    };
    config.aero_rows = parse_aero_csv(&csv_name, &csv_text)?;

    // The envelope map on board: only the top file's (an overlay is another
    // system, whose map its base's cannot be), read and checked against the
    // configuration's hash: a map of another configuration is not used (the
    // configuration has none, `stale_limits` says why; the firmware's build
    // refuses it through `check_limits`).
    const LIMITS_KEY: &str = "envelope.limits_map";
    if config.envelope.limits_map.is_some() && origins.file_of(LIMITS_KEY) != top.name {
        config.envelope.limits_map = None;
    }
    // Text given without its file names no file: its map is not read.
    let policy = match top.place {
        Place::Text { .. } => MapPolicy::Skip,
        _ => policy,
    };
    if let Some(relative) = config.envelope.limits_map.clone() {
        let read = || -> Result<_, ConfigError> {
            let file = top.open(LIMITS_KEY, &relative)?;
            let parsed = LimitsFile::parse(&file.name, &file.text)?;
            let map = parsed.to_grids(&file.name)?;
            Ok((parsed.stale_for(&file.name, &config), map, file.text))
        };
        let read = match policy {
            MapPolicy::Check => Some(read()?),
            MapPolicy::IfFresh => read().ok(),
            MapPolicy::Skip => None,
        };
        match read {
            Some((None, map, text)) => {
                config.limits = Some(map);
                config.limits_text = Some(text);
            }
            Some((Some(stale), ..)) => config.stale_limits = Some(stale),
            None => {}
        }
    }
    Ok(config)
}

/// `top` and its bases, base first.
fn chain(top: File) -> Result<Vec<File>, ConfigError> {
    let mut files = vec![top];
    loop {
        let file = files.last().expect("the chain is never empty");
        let table = DeTable::parse(&file.text)
            .map_err(|e| toml_error(&file.name, &file.text, e.message(), e.span()))?;
        let base = match table.get_ref().get(BASE_KEY).map(Spanned::get_ref) {
            None => break,
            Some(DeValue::String(base)) => base.to_string(),
            Some(other) => {
                return Err(ConfigError::Invalid {
                    file: file.name.clone(),
                    field: BASE_KEY.to_owned(),
                    message: format!(
                        "must be a string naming the base file, got {}",
                        value_kind(other)
                    ),
                });
            }
        };
        let next = file.open(BASE_KEY, &base)?;
        if files.iter().any(|f| f.identity == next.identity) {
            let mut names: Vec<String> = files.iter().map(|f| f.name.clone()).collect();
            names.push(next.name);
            return Err(ConfigError::BaseCycle {
                file: file.name.clone(),
                base,
                chain: names,
            });
        }
        files.push(next);
    }
    files.reverse();
    Ok(files)
}

/// What kind of TOML value `value` is, for messages.
fn value_kind(value: &DeValue<'_>) -> &'static str {
    match value {
        DeValue::String(_) => "a string",
        DeValue::Integer(_) => "an integer",
        DeValue::Float(_) => "a float",
        DeValue::Boolean(_) => "a boolean",
        DeValue::Datetime(_) => "a date-time",
        DeValue::Array(_) => "an array",
        DeValue::Table(_) => "a table",
    }
}

/// Merges `overlay` onto `base`: tables of the same name key by key, any other
/// value replaced (its key too, so that its span is the overlay's).
fn merge<'i>(base: &mut DeTable<'i>, overlay: DeTable<'i>) {
    for (key, value) in overlay {
        let existing = base.get_mut(key.get_ref().as_ref());
        if let Some(existing) = existing
            && let (DeValue::Table(into), DeValue::Table(_)) = (existing.get_mut(), value.get_ref())
        {
            let DeValue::Table(from) = value.into_inner() else {
                unreachable!("matched as a table above")
            };
            merge(into, from);
            continue;
        }
        base.remove(key.get_ref().as_ref());
        base.insert(key, value);
    }
}

/// Records, for every key path of `table` under `prefix`, `file` as the file
/// that wrote it: a value always (the last file to write it), a table only when
/// no file before introduced it.
fn record_origins(
    table: &DeTable<'_>,
    prefix: &str,
    file: &str,
    origins: &mut BTreeMap<String, String>,
) {
    for (key, value) in table {
        let path = format!("{prefix}{}", key.get_ref());
        match value.get_ref() {
            DeValue::Table(inner) => {
                origins
                    .entry(path.clone())
                    .or_insert_with(|| file.to_owned());
                record_origins(inner, &format!("{path}."), file, origins);
            }
            _ => {
                origins.insert(path, file.to_owned());
            }
        }
    }
}

/// `table` with every span moved on by `by` bytes (its place in the buffer of
/// every file's text).
fn shift_table(table: DeTable<'_>, by: usize) -> DeTable<'_> {
    table
        .into_iter()
        .map(|(key, value)| (shift(key, by), shift_value(value, by)))
        .collect()
}

fn shift_value(value: Spanned<DeValue<'_>>, by: usize) -> Spanned<DeValue<'_>> {
    let span = value.span();
    let inner = match value.into_inner() {
        DeValue::Table(table) => DeValue::Table(shift_table(table, by)),
        DeValue::Array(mut array) => {
            for element in array.iter_mut() {
                let taken = std::mem::replace(element, Spanned::new(0..0, DeValue::Boolean(false)));
                *element = shift_value(taken, by);
            }
            DeValue::Array(array)
        }
        other => other,
    };
    Spanned::new(span.start + by..span.end + by, inner)
}

fn shift<T>(spanned: Spanned<T>, by: usize) -> Spanned<T> {
    let span = spanned.span();
    Spanned::new(span.start + by..span.end + by, spanned.into_inner())
}
