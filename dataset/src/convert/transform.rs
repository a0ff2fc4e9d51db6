//! Rigid transforms of Drake's schema (`translation` + `!Identity`/`!Rpy`/`!AngleAxis`)
//! and the Drake (Z-up) → Habitat (Y-up) change of frame.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// A pose: rotation then translation.
pub type Pose = Isometry3<f64>;

/// Drake's roll-pitch-yaw (radians): R = Rz(yaw) · Ry(pitch) · Rx(roll).
pub fn rpy(roll: f64, pitch: f64, yaw: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), pitch)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), roll)
}

/// A pose from a translation and a rotation.
pub fn pose(translation: [f64; 3], rotation: UnitQuaternion<f64>) -> Pose {
    Isometry3::from_parts(Translation3::new(translation[0], translation[1], translation[2]), rotation)
}

/// C = Rx(−90°): Drake world (Z up, +Y forward) to Habitat world (Y up, −Z forward):
/// (x, y, z) → (x, z, −y).
pub fn drake_to_habitat() -> Rotation3<f64> {
    Rotation3::from_matrix_unchecked(Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0))
}

/// A point of the Drake world in the Habitat world.
pub fn point_to_habitat(p: Vector3<f64>) -> [f64; 3] {
    [p.x, p.z, -p.y]
}

/// A quaternion as Habitat writes it: `[w, x, y, z]`.
pub fn wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drake_up_and_front_become_habitats() {
        let c = drake_to_habitat();
        assert_eq!(c * Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.0, 1.0, 0.0));
        assert_eq!(c * Vector3::new(0.0, 1.0, 0.0), Vector3::new(0.0, 0.0, -1.0));
        let q = UnitQuaternion::from_rotation_matrix(&c);
        let expected = [std::f64::consts::FRAC_1_SQRT_2, -std::f64::consts::FRAC_1_SQRT_2, 0.0, 0.0];
        assert!(wxyz(&q).iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12));
    }

    #[test]
    fn rpy_follows_drakes_convention() {
        // Yaw 90° turns +X into +Y.
        let r = rpy(0.0, 0.0, std::f64::consts::FRAC_PI_2);
        assert!((r * Vector3::x() - Vector3::y()).norm() < 1e-12);
        // Roll then yaw: Rz · Rx applied to +Y gives Rz(+Z) = +Z.
        let r = rpy(std::f64::consts::FRAC_PI_2, 0.0, std::f64::consts::FRAC_PI_2);
        assert!((r * Vector3::y() - Vector3::z()).norm() < 1e-12);
    }
}
