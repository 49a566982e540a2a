//! A machine-readable description of every wire type, from the compiler's own
//! layout (`size_of`, `align_of`, `offset_of!`), so a mirror in another language
//! can be checked field by field against the real thing.

use decoy_schema::Manoeuvre;
use decoy_schema::{CSV_FILES, CsvFile, Requirement};
use serde::Serialize;

use crate::wire::*;
use crate::{PROTOCOL_VERSION, event, service};

/// One field of a wire type.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct FieldLayout {
    /// The field's name.
    pub name: &'static str,
    /// Byte offset from the start of the type.
    pub offset: usize,
    /// Bytes.
    pub size: usize,
    /// Element type: `u8`, `u16`, `u32`, `u64`, `f32`, `f64`, or the type name
    /// (`Header`, ...) of a nested wire type described in the same list.
    #[serde(rename = "type")]
    pub ty: &'static str,
    /// Elements: 1 for a scalar or struct, N for an array `[ty; N]`.
    pub count: usize,
}

/// One wire type.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TypeLayout {
    /// The Rust name (`Answer`).
    pub name: &'static str,
    /// The iceoryx2 type name (`decoy.bridge.v4.Answer`), which a mirror's
    /// `type_name()` must return.
    pub type_name: &'static str,
    /// `size_of`, bytes.
    pub size: usize,
    /// `align_of`, bytes.
    pub align: usize,
    /// Every field, in declaration (and offset) order.
    pub fields: Vec<FieldLayout>,
}

/// Everything a mirror needs: the types, the services, the event ids and the codes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LayoutDescription {
    /// [`PROTOCOL_VERSION`].
    pub protocol_version: u16,
    /// Every wire type, nested types before the types that hold them.
    pub types: Vec<TypeLayout>,
    /// Each service's last name part, its pattern and its payload types.
    pub services: Vec<ServiceLayout>,
    /// Event ids (name, value).
    pub event_ids: Vec<(&'static str, usize)>,
    /// Codes of the `kind`, `reason`, `command`, `profile`, `result`, `backend`
    /// and `health` fields (field, name, value).
    pub codes: Vec<(&'static str, &'static str, u64)>,
    /// The decoy management's requirements in wire order: the order of
    /// `Output`'s reports and of the advisory bits.
    pub requirements: Vec<RequirementLayout>,
    /// The columns of every CSV file the tools write (`decoy_schema::columns`):
    /// a client writing `decoy feed`'s files takes its column names from here.
    pub csv_files: Vec<CsvFile>,
}

/// One requirement of the decoy management (`decoy_schema::Requirement`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct RequirementLayout {
    /// Its name: the field of `Output` holding its report, the prefix of its
    /// columns.
    pub name: &'static str,
    /// Its bit in `Output::advisories`.
    pub bit: u8,
    /// The unit of its margin on the wire.
    pub unit: &'static str,
    /// The unit of its margin in the files (`deg` where the wire has `rad`).
    pub file_unit: &'static str,
    /// A title.
    pub title: &'static str,
    /// What its margin is.
    pub margin: &'static str,
}

impl RequirementLayout {
    fn of(r: Requirement) -> Self {
        RequirementLayout {
            name: r.name(),
            bit: r.bit(),
            unit: r.unit(),
            file_unit: r.file_unit(),
            title: r.title(),
            margin: r.margin(),
        }
    }
}

/// One service of an instance.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ServiceLayout {
    /// `decoy/<instance>/<name>`.
    pub name: &'static str,
    /// `request_response`, `publish_subscribe` or `event`.
    pub pattern: &'static str,
    /// Request or sample type (None for an event service).
    pub payload: Option<&'static str>,
    /// Response type (request-response only).
    pub response: Option<&'static str>,
}

/// The size of a field of `$t` (whose `Default` value is used for `size_of_val`).
macro_rules! field {
    ($t:ty, $f:ident, $ty:literal, $count:expr) => {
        FieldLayout {
            name: stringify!($f),
            offset: core::mem::offset_of!($t, $f),
            size: core::mem::size_of_val(&<$t>::default().$f),
            ty: $ty,
            count: $count,
        }
    };
}

macro_rules! layout {
    ($t:ident, [$(($f:ident, $ty:literal, $count:expr)),* $(,)?]) => {
        TypeLayout {
            name: stringify!($t),
            type_name: type_name_of::<$t>(),
            size: core::mem::size_of::<$t>(),
            align: core::mem::align_of::<$t>(),
            fields: vec![$(field!($t, $f, $ty, $count)),*],
        }
    };
}

/// `Output`'s layout: its fixed fields, then one report per requirement (the
/// fields `wire.rs` generates from the requirement list), then the envelope
/// map's limits (protocol 4).
fn output_layout() -> TypeLayout {
    macro_rules! output_layout {
        ($(($variant:ident, $field:ident, $($rest:tt)*)),* $(,)?) => {
            layout!(
                Output,
                [
                    (time_s, "f64", 1),
                    (request_seq, "u32", 1),
                    (connection_tension_n, "f32", 1),
                    (tow_tension_n, "f32", 1),
                    (decoy_position_fp_m, "f32", 3),
                    (decoy_euler_rel_rad, "f32", 3),
                    (angle_of_attack_rad, "f32", 1),
                    (cable_clearance_exhaust_m, "f32", 1),
                    (decoy_clearance_aircraft_m, "f32", 1),
                    (flags, "u16", 1),
                    (steps, "u16", 1),
                    (instructions, "u32", 1),
                    (step_instructions, "u32", 1),
                    (management_instructions, "u32", 1),
                    (prediction_from_s, "f64", 1),
                    (prediction_horizon_s, "f32", 1),
                    (prediction_steps, "u16", 1),
                    (advisories, "u8", 1),
                    (reserved, "u8", 1),
                    $(($field, "MonitorReport", 1),)*
                    (limit_pull_up_radps, "f32", 1),
                    (limit_turn_radps, "f32", 1),
                    (limit_acceleration_mps2, "f32", 1),
                    (floor_pull_up_radps, "f32", 1),
                    (floor_turn_radps, "f32", 1),
                    (floor_acceleration_mps2, "f32", 1),
                    (limited_by, "u8", 3),
                    (reserved_limits, "u8", 5),
                ]
            )
        };
    }
    decoy_schema::for_each_requirement!(output_layout)
}

/// The layout of every wire type, nested types first.
pub fn layouts() -> LayoutDescription {
    let types = vec![
        layout!(
            Header,
            [
                (protocol_version, "u16", 1),
                (kind, "u16", 1),
                (seq, "u32", 1)
            ]
        ),
        layout!(
            AircraftState,
            [
                (header, "Header", 1),
                (time_s, "f64", 1),
                (position_ned_m, "f64", 3),
                (velocity_ned_mps, "f32", 3),
                (acceleration_ned_mps2, "f32", 3),
                (attitude_wxyz, "f32", 4),
                (body_rate_radps, "f32", 3),
                (body_angular_acceleration_radps2, "f32", 3),
            ]
        ),
        layout!(
            MonitorReport,
            [
                (margin, "f32", 1),
                (worst_margin, "f32", 1),
                (predicted_worst_margin, "f32", 1),
                (time_to_violation_s, "f32", 1),
                (cautions, "u32", 1),
                (warnings, "u32", 1),
                (violations, "u32", 1),
                (level, "u8", 1),
                (reserved, "u8", 3),
            ]
        ),
        output_layout(),
        layout!(
            Rejection,
            [
                (request_seq, "u32", 1),
                (reason, "u16", 1),
                (reserved, "u16", 1),
                (count, "u64", 1)
            ]
        ),
        layout!(
            Answer,
            [
                (header, "Header", 1),
                (rejection, "Rejection", 1),
                (output, "Output", 1)
            ]
        ),
        layout!(
            Counters,
            [
                (accepted, "u64", 1),
                (commands, "u64", 1),
                (lockstep_requests, "u64", 1),
                (free_samples, "u64", 1),
                (non_finite, "u64", 1),
                (out_of_range, "u64", 1),
                (bad_quaternion, "u64", 1),
                (time_not_increasing, "u64", 1),
                (time_jump, "u64", 1),
                (not_trimmed, "u64", 1),
                (solver_failure, "u64", 1),
                (wrong_mode, "u64", 1),
                (wrong_version, "u64", 1),
                (wrong_type, "u64", 1),
                (backend_failure, "u64", 1),
                (overruns, "u64", 1),
                (lost, "u64", 1),
                (silences, "u64", 1),
            ]
        ),
        layout!(
            Status,
            [
                (header, "Header", 1),
                (time_s, "f64", 1),
                (uptime_s, "f64", 1),
                (input_age_s, "f64", 1),
                (counters, "Counters", 1),
                (grading_ratio, "f64", 1),
                (segments, "u16", 1),
                (capacity, "u16", 1),
                (precision_bits, "u8", 1),
                (backend, "u8", 1),
                (health, "u8", 1),
                (reserved0, "u8", 1),
                (controller_flags, "u16", 1),
                (link_protocol_version, "u16", 1),
                (reserved1, "u32", 1),
                (board, "u8", 24),
                (instance, "u8", 32),
            ]
        ),
        layout!(
            Command,
            [
                (header, "Header", 1),
                (command, "u16", 1),
                (profile, "u16", 1),
                (rate_milli_radps, "u16", 1),
                (reserved, "u16", 1),
                (nonce, "u32", 1),
                (reserved1, "u32", 1),
            ]
        ),
        layout!(
            CommandReply,
            [
                (header, "Header", 1),
                (request_seq, "u32", 1),
                (command, "u16", 1),
                (result, "u16", 1),
                (reason, "u16", 1),
                (reserved, "u16", 1),
                (nonce, "u32", 1),
                (status, "Status", 1),
            ]
        ),
    ];
    let type_name = |name: &str| types.iter().find(|t| t.name == name).map(|t| t.type_name);
    let services = vec![
        ServiceLayout {
            name: service::LOCKSTEP,
            pattern: "request_response",
            payload: type_name("AircraftState"),
            response: type_name("Answer"),
        },
        ServiceLayout {
            name: service::STATE,
            pattern: "publish_subscribe",
            payload: type_name("AircraftState"),
            response: None,
        },
        ServiceLayout {
            name: service::OUTPUTS,
            pattern: "publish_subscribe",
            payload: type_name("Answer"),
            response: None,
        },
        ServiceLayout {
            name: service::STATUS,
            pattern: "publish_subscribe",
            payload: type_name("Status"),
            response: None,
        },
        ServiceLayout {
            name: service::COMMANDS,
            pattern: "request_response",
            payload: type_name("Command"),
            response: type_name("CommandReply"),
        },
        ServiceLayout {
            name: service::TO_BRIDGE,
            pattern: "event",
            payload: None,
            response: None,
        },
        ServiceLayout {
            name: service::FROM_BRIDGE,
            pattern: "event",
            payload: None,
            response: None,
        },
    ];
    let event_ids = vec![
        ("REQUEST", event::REQUEST),
        ("STATE", event::STATE),
        ("COMMAND", event::COMMAND),
        ("ANSWER", event::ANSWER),
        ("OUTPUT", event::OUTPUT),
        ("STATUS", event::STATUS),
        ("COMMAND_REPLY", event::COMMAND_REPLY),
    ];
    let mut codes: Vec<(&'static str, &'static str, u64)> = Vec::new();
    for k in [
        kind::AIRCRAFT_STATE,
        kind::OUTPUT,
        kind::REJECTED,
        kind::STATUS,
        kind::COMMAND,
        kind::COMMAND_REPLY,
        kind::INITIALISING,
    ] {
        codes.push(("kind", kind::name(k), u64::from(k)));
    }
    for r in reason::ALL {
        codes.push(("reason", reason::name(r), u64::from(r)));
    }
    for (name, c) in [
        ("reset_to_trim", command::RESET_TO_TRIM),
        ("select_profile", command::SELECT_PROFILE),
        ("get_status", command::GET_STATUS),
        ("ping", command::PING),
    ] {
        codes.push(("command", name, u64::from(c)));
    }
    codes.push(("profile", "streamed", u64::from(profile::STREAMED)));
    for m in Manoeuvre::ALL {
        codes.push(("profile", m.ident(), u64::from(profile::of(m))));
    }
    for (name, bit) in flag::ALL {
        codes.push(("flag", name, u64::from(bit)));
    }
    codes.push(("result", "ok", u64::from(result::OK)));
    codes.push(("result", "rejected", u64::from(result::REJECTED)));
    for b in [backend::HOST, backend::QEMU] {
        codes.push(("backend", backend::name(b), u64::from(b)));
    }
    for h in [
        health::WAITING,
        health::RUNNING,
        health::DEGRADED,
        health::RECOVERED,
    ] {
        codes.push(("health", health::name(h), u64::from(h)));
    }
    LayoutDescription {
        protocol_version: PROTOCOL_VERSION,
        types,
        services,
        event_ids,
        codes,
        requirements: Requirement::ALL.map(RequirementLayout::of).to_vec(),
        csv_files: CSV_FILES.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scalar_size(ty: &str, all: &[TypeLayout]) -> usize {
        match ty {
            "u8" => 1,
            "u16" => 2,
            "u32" | "f32" => 4,
            "u64" | "f64" => 8,
            other => {
                all.iter()
                    .find(|t| t.name == other)
                    .unwrap_or_else(|| panic!("unknown field type {other}"))
                    .size
            }
        }
    }

    /// Every type is described completely: the fields follow each other with no
    /// gap and no overlap, their sizes are their types' and fill the type, so a
    /// mirror built from the description has the same bytes.
    #[test]
    fn descriptions_cover_every_byte_without_padding() {
        let d = layouts();
        assert_eq!(d.types.len(), 10);
        for t in &d.types {
            let mut next = 0;
            for f in &t.fields {
                assert_eq!(
                    f.offset, next,
                    "{}.{} starts at {}",
                    t.name, f.name, f.offset
                );
                assert_eq!(
                    f.size,
                    f.count * scalar_size(f.ty, &d.types),
                    "{}.{}",
                    t.name,
                    f.name
                );
                next += f.size;
            }
            assert_eq!(next, t.size, "{} has bytes no field describes", t.name);
            assert_eq!(t.size % t.align, 0);
            assert!(
                t.type_name.starts_with("decoy.bridge.v4."),
                "{}",
                t.type_name
            );
            assert_eq!(&t.type_name["decoy.bridge.v4.".len()..], t.name);
        }
    }

    /// The sizes a mirror must reproduce (a change here is a protocol change:
    /// bump PROTOCOL_VERSION and the type names).
    #[test]
    fn sizes_are_fixed() {
        let size = |n: &str| layouts().types.iter().find(|t| t.name == n).unwrap().size;
        assert_eq!(size("Header"), 8);
        assert_eq!(size("AircraftState"), 104);
        assert_eq!(size("MonitorReport"), 32);
        assert_eq!(size("Output"), 248);
        assert_eq!(size("Rejection"), 16);
        assert_eq!(size("Answer"), 272);
        assert_eq!(size("Counters"), 144);
        assert_eq!(size("Status"), 256);
        assert_eq!(size("Command"), 24);
        assert_eq!(size("CommandReply"), 280);
    }

    /// `Output` ends with one report per requirement, in the list's order, as
    /// before the fields were generated from it (offsets 88, 120, 152, 184);
    /// `report` and `reports` read those fields.
    #[test]
    fn the_reports_follow_the_requirement_list() {
        let d = layouts();
        let output = d.types.iter().find(|t| t.name == "Output").unwrap();
        let reports: Vec<(&str, usize)> = output
            .fields
            .iter()
            .filter(|f| f.ty == "MonitorReport")
            .map(|f| (f.name, f.offset))
            .collect();
        let expected: Vec<(&str, usize)> = Requirement::ALL
            .iter()
            .map(|r| (r.name(), 88 + 32 * r.index()))
            .collect();
        assert_eq!(reports, expected);
        let names: Vec<&str> = d.requirements.iter().map(|r| r.name).collect();
        let expected: Vec<&str> = Requirement::ALL.iter().map(|r| r.name()).collect();
        assert_eq!(names, expected);
        let mut out = Output::default();
        for r in Requirement::ALL {
            out.report_mut(r).cautions = r.index() as u32 + 1;
        }
        assert_eq!(out.tension.cautions, 3);
        for (r, report) in out.reports().iter() {
            assert_eq!(report.cautions, r.index() as u32 + 1);
            assert_eq!(out.report(r).cautions, r.index() as u32 + 1);
        }
    }

    #[test]
    fn services_and_codes_are_listed() {
        let d = layouts();
        assert_eq!(d.services.len(), service::ALL.len());
        for (s, name) in d.services.iter().zip(service::ALL) {
            assert_eq!(s.name, name);
        }
        let codes = |field: &str| d.codes.iter().filter(|c| c.0 == field).count();
        assert_eq!(codes("reason"), reason::ALL.len());
        assert_eq!(codes("kind"), 7);
        assert_eq!(codes("flag"), flag::ALL.len());
        assert!(d.codes.iter().all(|c| c.1 != "?"));
        let json = serde_json::to_string(&d).unwrap();
        assert!(json.contains("\"type_name\":\"decoy.bridge.v4.AircraftState\""));
    }
}
