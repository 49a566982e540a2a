//! Frames and clearances: the flight-path frame the outputs are expressed in, the
//! exhaust plume and the aircraft's collision envelope.

use decoy_config::AircraftConfig;
use nalgebra::Vector3;
use solver_core::AircraftState;

/// Speed below which the flight-path frame falls back to the aircraft's axes, m/s.
const MIN_SPEED_MPS: f64 = 1e-6;

/// The flight-path frame at one instant: x along the aircraft's velocity, y
/// horizontal and to the right of it, z = x cross y (downward, perpendicular to
/// the flight path in its vertical plane). Reduces to NED rotated to the heading
/// in level flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlightPathFrame {
    /// Unit x axis (along the velocity), NED.
    pub x: Vector3<f64>,
    /// Unit y axis (horizontal, right), NED.
    pub y: Vector3<f64>,
    /// Unit z axis (down, perpendicular to x and y), NED.
    pub z: Vector3<f64>,
}

impl FlightPathFrame {
    /// The frame of `aircraft`'s velocity; for a (near) zero or vertical velocity
    /// the aircraft's body axes stand in for the missing directions.
    pub fn of(aircraft: &AircraftState<f64>) -> Self {
        let rotation = aircraft.rotation();
        let speed = aircraft.velocity.norm();
        let x = if speed > MIN_SPEED_MPS {
            aircraft.velocity / speed
        } else {
            rotation * Vector3::x()
        };
        let right = Vector3::z().cross(&x);
        let y = if right.norm() > 1e-9 {
            right.normalize()
        } else {
            let body_y = rotation * Vector3::y();
            (body_y - x * x.dot(&body_y)).normalize()
        };
        FlightPathFrame {
            x,
            y,
            z: x.cross(&y),
        }
    }

    /// The components of the NED vector `r` along x, y, z.
    pub fn components(&self, r: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(self.x.dot(r), self.y.dot(r), self.z.dot(r))
    }
}

/// The hot exhaust plume: a truncated cone in the aircraft body frame starting at
/// the nozzle exit (radius `nozzle_radius`) and widening along `axis` with
/// `half_angle` for `length` metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExhaustPlume {
    /// Nozzle exit centre, body frame, m.
    pub nozzle: Vector3<f64>,
    /// Unit plume axis, body frame.
    pub axis: Vector3<f64>,
    /// Nozzle exit radius, m.
    pub nozzle_radius: f64,
    /// Tangent of the half angle.
    pub tan_half_angle: f64,
    /// Length of the plume, m.
    pub length: f64,
}

impl ExhaustPlume {
    /// The plume of an aircraft configuration.
    pub fn from_config(aircraft: &AircraftConfig) -> Self {
        let axis = Vector3::from(aircraft.exhaust_axis).normalize();
        ExhaustPlume {
            nozzle: Vector3::from(aircraft.exhaust_nozzle),
            axis,
            nozzle_radius: aircraft.exhaust_nozzle_radius,
            tan_half_angle: aircraft.exhaust_half_angle_deg.to_radians().tan(),
            length: aircraft.exhaust_length,
        }
    }

    /// Signed distance from the body-frame point `p` to the plume's surface
    /// (nozzle disc, conical side, end disc), m: positive outside, negative inside.
    ///
    /// Computed in the meridian half-plane: s along the axis from the nozzle, rho
    /// from the axis; the plume's section there is the trapezoid (0,0), (0,r0),
    /// (L, r0 + L tan a), (L,0), and the distance to the solid of revolution is
    /// the distance to the trapezoid's three edges off the axis.
    pub fn clearance(&self, p: &Vector3<f64>) -> f64 {
        let d = p - self.nozzle;
        let s = d.dot(&self.axis);
        let rho = (d - self.axis * s).norm();
        let end_radius = self.nozzle_radius + self.length * self.tan_half_angle;
        let q = [s, rho];
        let distance = segment_distance(q, [0.0, 0.0], [0.0, self.nozzle_radius])
            .min(segment_distance(
                q,
                [0.0, self.nozzle_radius],
                [self.length, end_radius],
            ))
            .min(segment_distance(
                q,
                [self.length, end_radius],
                [self.length, 0.0],
            ));
        let inside =
            (0.0..=self.length).contains(&s) && rho <= self.nozzle_radius + s * self.tan_half_angle;
        if inside { -distance } else { distance }
    }
}

/// The aircraft's collision envelope: a capsule (a segment swept by a sphere) in
/// the body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Envelope {
    /// Fore end of the axis, body frame, m.
    pub fore: Vector3<f64>,
    /// Aft end of the axis, body frame, m.
    pub aft: Vector3<f64>,
    /// Radius, m.
    pub radius: f64,
}

impl Envelope {
    /// The envelope of an aircraft configuration.
    pub fn from_config(aircraft: &AircraftConfig) -> Self {
        Envelope {
            fore: Vector3::from(aircraft.envelope_fore),
            aft: Vector3::from(aircraft.envelope_aft),
            radius: aircraft.envelope_radius,
        }
    }

    /// Distance from the body-frame point `p` to the capsule's surface, m
    /// (negative inside).
    pub fn clearance(&self, p: &Vector3<f64>) -> f64 {
        let axis = self.aft - self.fore;
        let length2 = axis.norm_squared();
        let t = if length2 > 0.0 {
            ((p - self.fore).dot(&axis) / length2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (self.fore + axis * t)).norm() - self.radius
    }
}

/// Distance from `q` to the segment a-b in the plane.
fn segment_distance(q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let aq = [q[0] - a[0], q[1] - a[1]];
    let length2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if length2 > 0.0 {
        ((aq[0] * ab[0] + aq[1] * ab[1]) / length2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let dx = aq[0] - t * ab[0];
    let dy = aq[1] - t * ab[1];
    (dx * dx + dy * dy).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plume() -> ExhaustPlume {
        ExhaustPlume {
            nozzle: Vector3::new(-7.5, 0.0, 0.0),
            axis: Vector3::new(-1.0, 0.0, 0.0),
            nozzle_radius: 0.5,
            tan_half_angle: 0.1,
            length: 50.0,
        }
    }

    #[test]
    fn plume_clearance_signs_and_values() {
        let p = plume();
        // 10 m behind the nozzle the plume radius is 1.5 m.
        let behind = |s: f64, rho: f64| Vector3::new(-7.5 - s, 0.0, rho);
        let side = |s: f64, rho: f64| p.clearance(&behind(s, rho));
        // Outside, perpendicular distance to the cone's side.
        let c = side(10.0, 3.5);
        // (rho - r(s)) times the cosine of the half angle.
        let expected = 2.0 * 0.1f64.atan().cos();
        assert!((c - expected).abs() < 1e-12, "{c} vs {expected}");
        assert!(c > 0.0);
        // On the axis, inside: distance to the side (or the nozzle disc).
        assert!(side(10.0, 0.0) < 0.0);
        assert!((side(0.1, 0.0) + 0.1).abs() < 1e-12);
        // In front of the nozzle: distance to the disc.
        assert!((side(-2.0, 0.2) - 2.0).abs() < 1e-12);
        // Beyond the end: distance to the end disc.
        assert!((side(53.0, 0.0) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn capsule_clearance() {
        let e = Envelope {
            fore: Vector3::new(7.0, 0.0, 0.0),
            aft: Vector3::new(-7.5, 0.0, 0.0),
            radius: 1.6,
        };
        assert!((e.clearance(&Vector3::new(0.0, 0.0, 5.0)) - 3.4).abs() < 1e-12);
        assert!((e.clearance(&Vector3::new(-10.5, 0.0, 4.0)) - 3.4).abs() < 1e-12);
        assert!(e.clearance(&Vector3::zeros()) < 0.0);
    }

    #[test]
    fn flight_path_frame_in_a_climb() {
        let mut a = AircraftState::<f64>::level(9000.0, 100.0);
        a.velocity = Vector3::new(100.0 * 0.5f64.cos(), 0.0, -100.0 * 0.5f64.sin());
        let f = FlightPathFrame::of(&a);
        assert!((f.y - Vector3::y()).norm() < 1e-12);
        // z is "down" perpendicular to the climbing path: it leans forward.
        assert!(f.z.z > 0.0 && f.z.x > 0.0);
        let c = f.components(&Vector3::new(-1.0, 0.0, 0.0));
        assert!(c.x < 0.0);
    }
}
