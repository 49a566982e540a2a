//! A recorded flight: the aircraft's state sampled in time (CSV), interpolated
//! into a [`FlightPath`] smooth enough for the solver.
//!
//! # The CSV
//!
//! `#` comment lines and blank lines are skipped; the first other line is the
//! header, exactly the columns [`RECORDED_COLUMNS`] in that order (the column
//! schema's `recorded_flight`, docs/outputs.md):
//! time (s, strictly increasing), position of the aircraft reference point (NED,
//! m), velocity (NED, m/s), attitude (Hamilton quaternion, scalar first, body FRD
//! to NED, unit length within 1e-3; it is normalised) and body rates (FRD, rad/s).
//! Every value must be finite, altitudes (`-down_m`) within 0 to 20 000 m, and the
//! positions must follow the velocities: over each interval the mean of the two
//! recorded velocities must match the position difference over the time
//! difference within 1 m/s + 1 % of the speed (this catches feet for metres, a
//! sign or a column swap; smooth data match it to millimetres per second). The
//! accelerations the interpolation implies must stay within
//! [`MAX_RECORDED_ACCELERATION_MPS2`] (a typed error,
//! [`crate::SimError::RecordedAcceleration`], naming the row), and a scenario
//! checks that the airspeed stays within Mach 2 ([`RecordedFlight::check_mach`]).
//!
//! # Interpolation
//!
//! On each interval [t_k, t_k+1] of length h, with s = (t - t_k)/h:
//!
//! - position: the cubic Hermite curve through p_k, p_k+1 with the recorded
//!   velocities v_k, v_k+1 as slopes; velocity is its derivative (continuous
//!   everywhere, equal to the recorded velocities at the samples) and acceleration
//!   its second derivative (linear on each interval). So position, velocity and
//!   acceleration are mutually consistent, as the solver's RK4 needs.
//! - attitude: spherical linear interpolation (shortest path).
//! - body rates: linear; angular acceleration: (w_k+1 - w_k)/h on the interval.
//!
//! At the sample times position, velocity, attitude and rates are the recorded
//! values exactly. Simulation time 0 is the first sample; beyond the last sample
//! the aircraft flies on in a straight line at its last velocity and attitude.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use solver_core::{AircraftState, FlightPath, Real};

use decoy_config::SystemConfig;

use decoy_schema::columns::{RECORDED_FLIGHT, column_names};

use crate::error::SimError;
use crate::format::format_number;

/// The recorded-flight CSV header, in order (the column schema's
/// `decoy_schema::columns::RECORDED_FLIGHT`).
pub const RECORDED_COLUMNS: [&str; RECORDED_FLIGHT.columns.len()] =
    column_names(RECORDED_FLIGHT.columns);

/// How far a recorded attitude quaternion's norm may be from 1.
const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;
/// Velocity-consistency tolerance: absolute part, m/s.
const CONSISTENCY_ABSOLUTE_MPS: f64 = 1.0;
/// Velocity-consistency tolerance: part relative to the speed.
const CONSISTENCY_RELATIVE: f64 = 0.01;
/// Altitude range of the atmosphere model, m.
const ALTITUDE_RANGE_M: (f64, f64) = (0.0, 20_000.0);
/// Largest acceleration a recording may imply, m/s² (about 10 g): the cubic
/// Hermite interpolation's acceleration at either end of every interval.
pub const MAX_RECORDED_ACCELERATION_MPS2: f64 = 100.0;

/// One sample of a recorded flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecordedSample {
    /// Time, s.
    pub time: f64,
    /// Position of the aircraft reference point, NED, m.
    pub position: Vector3<f64>,
    /// Velocity, NED, m/s.
    pub velocity: Vector3<f64>,
    /// Attitude, body (FRD) to NED.
    pub attitude: UnitQuaternion<f64>,
    /// Body rates (p, q, r), rad/s.
    pub body_rate: Vector3<f64>,
}

impl RecordedSample {
    /// The sample of a flight path at `t` (for writing recordings of computed paths).
    pub fn of_path<P: FlightPath<f64> + ?Sized>(path: &P, t: f64) -> Self {
        let s = path.state_at(t);
        RecordedSample {
            time: t,
            position: s.position,
            velocity: s.velocity,
            attitude: s.rotation(),
            body_rate: s.angular_rate,
        }
    }

    fn values(&self) -> [f64; 14] {
        let q = self.attitude.quaternion();
        [
            self.time,
            self.position.x,
            self.position.y,
            self.position.z,
            self.velocity.x,
            self.velocity.y,
            self.velocity.z,
            q.w,
            q.i,
            q.j,
            q.k,
            self.body_rate.x,
            self.body_rate.y,
            self.body_rate.z,
        ]
    }
}

/// A validated recorded flight (at least two samples, strictly increasing times).
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedFlight {
    samples: Vec<RecordedSample>,
    /// The file the samples came from, for messages.
    file: String,
    /// The line of each sample (the sample's index for samples from memory).
    lines: Vec<usize>,
}

/// Where a row came from, for messages.
struct RowError<'a> {
    file: &'a str,
}

impl RowError<'_> {
    fn at(&self, line: Option<usize>, column: Option<&str>, message: String) -> SimError {
        SimError::RecordedFlight {
            file: self.file.to_owned(),
            line,
            column: column.map(str::to_owned),
            message,
        }
    }
}

impl RecordedFlight {
    /// Parses and validates the CSV text of a recording (see the module docs);
    /// `file` names it in messages, which give the line and column of a problem.
    pub fn parse(file: &str, text: &str) -> Result<Self, SimError> {
        let err = RowError { file };
        let mut header_seen = false;
        let mut samples: Vec<RecordedSample> = Vec::new();
        let mut lines: Vec<usize> = Vec::new();
        for (index, raw) in text.lines().enumerate() {
            let number = index + 1;
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if !header_seen {
                if fields != RECORDED_COLUMNS {
                    return Err(err.at(
                        Some(number),
                        None,
                        format!(
                            "expected the header `{}`, found `{line}`",
                            RECORDED_COLUMNS.join(",")
                        ),
                    ));
                }
                header_seen = true;
                continue;
            }
            if fields.len() != RECORDED_COLUMNS.len() {
                return Err(err.at(
                    Some(number),
                    None,
                    format!(
                        "expected {} values, found {}",
                        RECORDED_COLUMNS.len(),
                        fields.len()
                    ),
                ));
            }
            let mut v = [0.0; 14];
            for ((value, name), field) in v.iter_mut().zip(RECORDED_COLUMNS).zip(&fields) {
                let parsed: f64 = field.parse().map_err(|_| {
                    err.at(
                        Some(number),
                        Some(name),
                        format!("`{field}` is not a number"),
                    )
                })?;
                if !parsed.is_finite() {
                    return Err(err.at(
                        Some(number),
                        Some(name),
                        format!("`{field}` is not a finite number"),
                    ));
                }
                *value = parsed;
            }
            let q = Quaternion::new(v[7], v[8], v[9], v[10]);
            let norm = q.norm();
            if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                return Err(err.at(
                    Some(number),
                    Some("qw"),
                    format!(
                        "the attitude quaternion (qw,qx,qy,qz) has norm {norm}, not 1 (within {QUATERNION_NORM_TOLERANCE})"
                    ),
                ));
            }
            samples.push(RecordedSample {
                time: v[0],
                position: Vector3::new(v[1], v[2], v[3]),
                velocity: Vector3::new(v[4], v[5], v[6]),
                // Unit to round-off: kept bit for bit (a written recording reads back
                // unchanged); otherwise normalised.
                attitude: if (norm - 1.0).abs() < 1e-12 {
                    UnitQuaternion::new_unchecked(q)
                } else {
                    UnitQuaternion::from_quaternion(q)
                },
                body_rate: Vector3::new(v[11], v[12], v[13]),
            });
            lines.push(number);
        }
        if !header_seen {
            return Err(err.at(
                None,
                None,
                format!("no header line `{}` found", RECORDED_COLUMNS.join(",")),
            ));
        }
        Self::validate(&samples, |row| Some(lines[row]), &err)?;
        Ok(RecordedFlight {
            samples,
            file: file.to_owned(),
            lines,
        })
    }

    /// A recording from samples already in memory (validated as a parsed file
    /// would be; messages name the zero-based sample as `line`).
    pub fn from_samples(samples: Vec<RecordedSample>) -> Result<Self, SimError> {
        let err = RowError { file: "samples" };
        for (row, s) in samples.iter().enumerate() {
            if !s.values().iter().all(|v| v.is_finite()) {
                return Err(err.at(Some(row), None, "a value is not finite".to_owned()));
            }
        }
        Self::validate(&samples, Some, &err)?;
        let lines = (0..samples.len()).collect();
        Ok(RecordedFlight {
            samples,
            file: err.file.to_owned(),
            lines,
        })
    }

    fn validate(
        samples: &[RecordedSample],
        line: impl Fn(usize) -> Option<usize>,
        err: &RowError<'_>,
    ) -> Result<(), SimError> {
        if samples.len() < 2 {
            return Err(err.at(
                None,
                None,
                format!("needs at least two samples, found {}", samples.len()),
            ));
        }
        let (h_min, h_max) = ALTITUDE_RANGE_M;
        for (row, s) in samples.iter().enumerate() {
            let altitude = -s.position.z;
            if !(h_min..=h_max).contains(&altitude) {
                return Err(err.at(
                    line(row),
                    Some("down_m"),
                    format!("altitude {altitude} m (= -down_m) is outside {h_min} to {h_max} m"),
                ));
            }
        }
        for row in 1..samples.len() {
            let (a, b) = (&samples[row - 1], &samples[row]);
            let h = b.time - a.time;
            if h <= 0.0 {
                return Err(err.at(
                    line(row),
                    Some("t_s"),
                    format!(
                        "time {} does not increase on the previous sample's {} (times must increase strictly)",
                        b.time, a.time
                    ),
                ));
            }
            let mean_velocity = (a.velocity + b.velocity) * 0.5;
            let chord_velocity = (b.position - a.position) / h;
            let mismatch = (chord_velocity - mean_velocity).norm();
            let tolerance = CONSISTENCY_ABSOLUTE_MPS + CONSISTENCY_RELATIVE * mean_velocity.norm();
            if mismatch > tolerance {
                return Err(err.at(
                    line(row),
                    Some("north_m"),
                    format!(
                        "the position does not follow the velocities: the change of position since the previous sample over its time is {mismatch:.3} m/s from the mean recorded velocity (more than {tolerance:.3} m/s); are positions in m, velocities in m/s, both NED?"
                    ),
                ));
            }
            // The Hermite curve's acceleration is linear on the interval: its
            // largest magnitude is at one of the ends,
            // a(0) = (6 dp - h (4 v_a + 2 v_b)) / h², a(1) = (-6 dp + h (2 v_a + 4 v_b)) / h².
            let dp = b.position - a.position;
            let start = (dp * 6.0 - (a.velocity * 4.0 + b.velocity * 2.0) * h) / (h * h);
            let end = (dp * -6.0 + (a.velocity * 2.0 + b.velocity * 4.0) * h) / (h * h);
            let acceleration = start.norm().max(end.norm());
            if acceleration.is_nan() || acceleration > MAX_RECORDED_ACCELERATION_MPS2 {
                return Err(SimError::RecordedAcceleration {
                    file: err.file.to_owned(),
                    line: line(row),
                    t0_s: a.time,
                    t1_s: b.time,
                    acceleration_mps2: acceleration,
                    limit_mps2: MAX_RECORDED_ACCELERATION_MPS2,
                });
            }
        }
        Ok(())
    }

    /// Checks that every sample flies within Mach `max_mach` through the air of
    /// `config` (its atmosphere and wind), the envelope `--mach` and the scenario
    /// files have; the error names the sample's line.
    pub fn check_mach(&self, config: &SystemConfig, max_mach: f64) -> Result<(), SimError> {
        let wind = Vector3::from(config.environment.wind_ned);
        for (s, &line) in self.samples.iter().zip(&self.lines) {
            let altitude = -s.position.z;
            let airspeed = (s.velocity - wind).norm();
            let mach = airspeed / config.speed_of_sound(altitude)?;
            if mach.is_nan() || mach > max_mach {
                return Err(SimError::RecordedFlight {
                    file: self.file.clone(),
                    line: Some(line),
                    column: Some("vn_mps".to_owned()),
                    message: format!(
                        "the airspeed {} m/s at {} m is Mach {}, above Mach {max_mach} (the envelope of --mach and of the scenario files)",
                        format_number(airspeed),
                        format_number(altitude),
                        format_number((mach * 1000.0).round() / 1000.0)
                    ),
                });
            }
        }
        Ok(())
    }

    /// The samples.
    pub fn samples(&self) -> &[RecordedSample] {
        &self.samples
    }

    /// Time from the first to the last sample, s (the longest simulation it covers).
    pub fn duration(&self) -> f64 {
        self.samples[self.samples.len() - 1].time - self.samples[0].time
    }

    /// The recording as CSV text (header and one row per sample, every value with
    /// the shortest representation that parses back to the same `f64`).
    pub fn to_csv(&self) -> String {
        let mut text = RECORDED_COLUMNS.join(",");
        text.push('\n');
        for s in &self.samples {
            let row: Vec<String> = s.values().iter().map(|v| format!("{v}")).collect();
            text.push_str(&row.join(","));
            text.push('\n');
        }
        text
    }

    /// The state at recording time `t` (absolute, as in the file).
    pub fn state_at_recorded_time(&self, t: f64) -> AircraftState<f64> {
        let samples = &self.samples;
        let first = &samples[0];
        let last = &samples[samples.len() - 1];
        if t < first.time || t > last.time || t.is_nan() {
            // Outside the recording: straight flight at the nearest sample's velocity.
            let s = if t < first.time || t.is_nan() {
                first
            } else {
                last
            };
            return state(
                s.position + s.velocity * (t - s.time),
                s.velocity,
                Vector3::zeros(),
                &s.attitude,
                s.body_rate,
                Vector3::zeros(),
            );
        }
        // Interval k with t_k <= t < t_k+1 (the last interval includes its end).
        let k = samples
            .partition_point(|s| s.time <= t)
            .saturating_sub(1)
            .min(samples.len() - 2);
        let (a, b) = (&samples[k], &samples[k + 1]);
        let h = b.time - a.time;
        let w_dot = (b.body_rate - a.body_rate) / h;
        if t == a.time {
            return state(
                a.position,
                a.velocity,
                hermite_acceleration(a, b, 0.0),
                &a.attitude,
                a.body_rate,
                w_dot,
            );
        }
        let s = ((t - a.time) / h).clamp(0.0, 1.0);
        let s2 = s * s;
        let s3 = s2 * s;
        // Cubic Hermite basis, its first and second derivatives with respect to s.
        let (h00, h10, h01, h11) = (
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        );
        let (d00, d10, d01, d11) = (
            6.0 * s2 - 6.0 * s,
            3.0 * s2 - 4.0 * s + 1.0,
            -6.0 * s2 + 6.0 * s,
            3.0 * s2 - 2.0 * s,
        );
        let position =
            a.position * h00 + a.velocity * (h10 * h) + b.position * h01 + b.velocity * (h11 * h);
        let velocity =
            (a.position * d00 + b.position * d01) / h + a.velocity * d10 + b.velocity * d11;
        state(
            position,
            velocity,
            hermite_acceleration(a, b, s),
            &slerp(&a.attitude, &b.attitude, s),
            a.body_rate * (1.0 - s) + b.body_rate * s,
            w_dot,
        )
    }
}

/// Second derivative of the Hermite curve of the interval a-b at parameter s, m/s^2.
fn hermite_acceleration(a: &RecordedSample, b: &RecordedSample, s: f64) -> Vector3<f64> {
    let h = b.time - a.time;
    let (e00, e10, e01, e11) = (
        12.0 * s - 6.0,
        6.0 * s - 4.0,
        -12.0 * s + 6.0,
        6.0 * s - 2.0,
    );
    (a.position * e00 + b.position * e01) / (h * h) + (a.velocity * e10 + b.velocity * e11) / h
}

/// Spherical linear interpolation along the shorter arc; exact at s = 0 and 1.
fn slerp(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>, s: f64) -> UnitQuaternion<f64> {
    if s <= 0.0 {
        return *a;
    }
    if s >= 1.0 {
        return *b;
    }
    let qa = a.coords;
    let mut qb = b.coords;
    let mut cos = qa.dot(&qb);
    if cos < 0.0 {
        qb = -qb;
        cos = -cos;
    }
    let q = if cos > 0.9995 {
        qa * (1.0 - s) + qb * s
    } else {
        let theta = cos.clamp(-1.0, 1.0).acos();
        let sin = theta.sin();
        qa * (((1.0 - s) * theta).sin() / sin) + qb * ((s * theta).sin() / sin)
    };
    UnitQuaternion::from_quaternion(Quaternion::from(q))
}

fn state(
    position: Vector3<f64>,
    velocity: Vector3<f64>,
    acceleration: Vector3<f64>,
    attitude: &UnitQuaternion<f64>,
    angular_rate: Vector3<f64>,
    angular_acceleration: Vector3<f64>,
) -> AircraftState<f64> {
    let q = attitude.quaternion();
    AircraftState {
        position,
        velocity,
        acceleration,
        attitude: [q.w, q.i, q.j, q.k],
        angular_rate,
        angular_acceleration,
    }
}

impl RecordedFlight {
    /// The state at simulation time `t`: recording time `t` + the first sample's time.
    pub fn state_at(&self, t: f64) -> AircraftState<f64> {
        self.state_at_recorded_time(self.samples[0].time + t)
    }
}

/// Interpolated in f64 and rounded to `T`.
impl<T: Real> FlightPath<T> for RecordedFlight {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        to_precision(&RecordedFlight::state_at(self, t))
    }
}

/// An f64 aircraft state rounded to `T`.
pub(crate) fn to_precision<T: Real>(s: &AircraftState<f64>) -> AircraftState<T> {
    let v = |v: &Vector3<f64>| Vector3::new(T::lit(v.x), T::lit(v.y), T::lit(v.z));
    AircraftState {
        position: v(&s.position),
        velocity: v(&s.velocity),
        acceleration: v(&s.acceleration),
        attitude: s.attitude.map(T::lit),
        angular_rate: v(&s.angular_rate),
        angular_acceleration: v(&s.angular_acceleration),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(t: f64, n: f64, v: f64) -> String {
        format!("{t},{n},0,-9000,{v},0,0,1,0,0,0,0,0,0\n")
    }

    fn csv(rows: &[String]) -> String {
        let mut s = format!("# a comment\n{}\n", RECORDED_COLUMNS.join(","));
        for r in rows {
            s.push_str(r);
        }
        s
    }

    #[test]
    fn straight_flight_interpolates_linearly() {
        let text = csv(&[line(0.0, 0.0, 200.0), line(1.0, 200.0, 200.0)]);
        let f = RecordedFlight::parse("x.csv", &text).unwrap();
        let s = f.state_at(0.25);
        assert!((s.position.x - 50.0).abs() < 1e-12);
        assert!((s.velocity.x - 200.0).abs() < 1e-12);
        assert!(s.acceleration.norm() < 1e-9);
        assert!((f.duration() - 1.0).abs() < 1e-15);
        // The same path for an f32 solver.
        let s32: AircraftState<f32> = FlightPath::<f32>::state_at(&f, 0.25);
        assert_eq!(s32.position.x, 50.0f32);
        assert_eq!(s32.attitude, [1.0f32, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn errors_name_line_and_column() {
        let text = csv(&[line(0.0, 0.0, 200.0), line(0.0, 200.0, 200.0)]);
        let e = RecordedFlight::parse("x.csv", &text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.csv, line 4, column t_s"), "{e}");
        let text = csv(&[
            line(0.0, 0.0, 200.0),
            "1,2,x,4,5,6,7,1,0,0,0,0,0,0\n".into(),
        ]);
        let e = RecordedFlight::parse("x.csv", &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 4, column east_m: `x` is not a number"),
            "{e}"
        );
        let text = csv(&[line(0.0, 0.0, 200.0), line(1.0, 600.0, 200.0)]);
        let e = RecordedFlight::parse("x.csv", &text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("does not follow"), "{e}");
        let e = RecordedFlight::parse("x.csv", "t,x\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 1") && e.contains("expected the header"),
            "{e}"
        );
        let text = csv(&[line(0.0, 0.0, 200.0)]);
        let e = RecordedFlight::parse("x.csv", &text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least two samples"), "{e}");
        let text = csv(&[
            line(0.0, 0.0, 200.0),
            "1,200,0,-9000,200,0,0,2,0,0,0,0,0,0\n".into(),
        ]);
        let e = RecordedFlight::parse("x.csv", &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 4, column qw") && e.contains("norm 2"),
            "{e}"
        );
    }

    #[test]
    fn slerp_takes_the_short_way_and_hits_the_ends() {
        let a = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.1);
        let b = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.5);
        let neg_b = UnitQuaternion::new_unchecked(-b.into_inner());
        let m = slerp(&a, &neg_b, 0.5);
        assert!((m.euler_angles().2 - 0.3).abs() < 1e-12);
        assert_eq!(slerp(&a, &b, 0.0), a);
        assert_eq!(slerp(&a, &b, 1.0), b);
    }
}
