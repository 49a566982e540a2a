//! The arguments every call takes alike: the configuration (None, a path or
//! a dict) and a segment count.

use std::path::PathBuf;

use decoy_config::SystemConfig;
use decoy_sim::scenario::MAX_SEGMENTS;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyMapping;

use crate::convert;
use crate::errors::{argument_error, config_error};

/// How a dict given as the configuration is named in messages.
const CONFIG_DICT: &str = "config dict";

/// The system configuration: `None` the built-in reference system, a path a
/// TOML file (as `--config`), a dict that file's tables.
pub(crate) fn load_config(config: Option<&Bound<'_, PyAny>>) -> PyResult<SystemConfig> {
    load(config, true)
}

/// [`load_config`] for the envelope map, which makes the map on board (as
/// `decoy envelope`: a stale map must not stop it; one made for the
/// configuration is used by the controller flown beside the runs).
pub(crate) fn load_config_for_mapping(config: Option<&Bound<'_, PyAny>>) -> PyResult<SystemConfig> {
    load(config, false)
}

fn load(config: Option<&Bound<'_, PyAny>>, mapped: bool) -> PyResult<SystemConfig> {
    let loaded = match config {
        None if mapped => SystemConfig::builtin(),
        None => SystemConfig::builtin_for_mapping(),
        Some(c) if c.cast::<PyMapping>().is_ok() => {
            let text = convert::toml_text(c, CONFIG_DICT)?;
            let dir = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
            if mapped {
                SystemConfig::from_text_in(CONFIG_DICT, &text, &dir)
            } else {
                SystemConfig::from_text_in_for_mapping(CONFIG_DICT, &text, &dir)
            }
        }
        Some(c) => match c.extract::<PathBuf>() {
            Ok(path) if mapped => SystemConfig::from_file(path),
            Ok(path) => SystemConfig::from_file_for_mapping(path),
            Err(_) => {
                return Err(PyTypeError::new_err(format!(
                    "config: expected None, a path or a dict, got a {}",
                    c.get_type().name()?
                )));
            }
        },
    };
    loaded.map_err(|e| config_error(&e))
}

/// A segment count as the command line takes it (`--segments N`): a negative
/// one is refused with the range the solver accepts.
pub(crate) fn segment_count(segments: Option<i64>) -> PyResult<Option<usize>> {
    segments
        .map(|n| {
            usize::try_from(n).map_err(|_| {
                argument_error(
                    "--segments",
                    format!("must be between 1 and {MAX_SEGMENTS}, got {n}"),
                )
            })
        })
        .transpose()
}
