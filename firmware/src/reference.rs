//! The reference towed-decoy system, the project's built-in configuration.
//!
//! The constants mirror `config/reference-system.toml` and the aerodynamic table it
//! names (`config/decoy-aero.csv`): `build.rs` generates them from those files at
//! build time, so the firmware and the host tools read the same numbers.

use decoy_link::{Envelope, ExhaustPlume, Geometry};
use solver_core::{
    AeroTable, AeroTableError, Atmosphere, CableParams, DecoyParams, EndBody, Environment,
    ModelParams, Real, SegmentLayout, Vec3,
};

/// The generated constants (see `build.rs`).
mod generated {
    include!(concat!(env!("OUT_DIR"), "/reference.rs"));
}

pub use generated::*;

/// A configuration triple as a solver vector.
fn vec3<T: Real>(v: [f64; 3]) -> Vec3<T> {
    Vec3::new(T::lit(v[0]), T::lit(v[1]), T::lit(v[2]))
}

/// The embedded model's discretisation: `solver.segments_embedded` segments graded
/// by `solver.grading_ratio_embedded`, the shortest at the decoy.
pub fn embedded_layout<T: Real>() -> SegmentLayout<T> {
    SegmentLayout::Graded {
        count: SEGMENTS_EMBEDDED,
        ratio: T::lit(GRADING_RATIO_EMBEDDED),
    }
}

/// The solver's parameters for the reference system with `layout` (the decoy at
/// the end of the chain, the ISA 1976 atmosphere with the configured constants).
pub fn model_params<T: Real>(layout: SegmentLayout<T>) -> Result<ModelParams<T>, AeroTableError> {
    let t = T::lit;
    Ok(ModelParams {
        environment: Environment {
            gravity: t(GRAVITY),
            wind: vec3(WIND_NED),
            atmosphere: Atmosphere::Isa1976 {
                gas_constant: t(GAS_CONSTANT),
                gamma: t(GAMMA),
                gravity: t(GRAVITY),
            },
        },
        connection_point: vec3(CONNECTION_POINT),
        cable: CableParams {
            length: t(CABLE_LENGTH),
            diameter: t(CABLE_DIAMETER),
            linear_density: t(CABLE_LINEAR_DENSITY),
            cd_normal: t(CABLE_CD_NORMAL),
            cf_tangential: t(CABLE_CF_TANGENTIAL),
        },
        layout,
        end: EndBody::Decoy(DecoyParams {
            mass: t(DECOY_MASS),
            length: t(DECOY_LENGTH),
            diameter: t(DECOY_DIAMETER),
            x_cg: t(DECOY_X_CG),
            x_tow: t(DECOY_X_TOW),
            x_mrp: t(DECOY_X_MRP),
            inertia_cg: vec3(DECOY_INERTIA_CG),
            cm_q: t(DECOY_CM_Q),
            cl_p: t(DECOY_CL_P),
            aero: AeroTable::from_degrees(&AERO_ROWS)?,
        }),
    })
}

/// The aircraft's exhaust plume and collision capsule (`[aircraft]`), with the
/// plume axis and half-angle tangent derived in f64 by `build.rs`.
pub fn geometry<T: Real>() -> Geometry<T> {
    Geometry {
        plume: ExhaustPlume {
            nozzle: vec3(EXHAUST_NOZZLE),
            axis: vec3(EXHAUST_AXIS_UNIT),
            nozzle_radius: T::lit(EXHAUST_NOZZLE_RADIUS),
            tan_half_angle: T::lit(EXHAUST_TAN_HALF_ANGLE),
            length: T::lit(EXHAUST_LENGTH),
        },
        envelope: Envelope {
            fore: vec3(ENVELOPE_FORE),
            aft: vec3(ENVELOPE_AFT),
            radius: T::lit(ENVELOPE_RADIUS),
        },
    }
}
