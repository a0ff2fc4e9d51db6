//! `traj.txt`: one camera-to-world pose per frame, 16 numbers per line (row-major 4×4,
//! OpenCV camera axes), as HaDaGe writes it.

use std::path::Path;

use nalgebra::Matrix4;

use crate::error::{InputError, Result};
use crate::numeric::c_exponent;

/// Camera-to-world poses, one per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// The poses in frame order.
    pub poses: Vec<Matrix4<f64>>,
}

impl Trajectory {
    /// Parse `traj.txt`: every non-empty line holds 16 finite numbers whose last row is 0 0 0 1.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
        let mut poses = Vec::new();
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let field = format!("line {}", i + 1);
            let values = line
                .split_whitespace()
                .map(|w| w.parse::<f64>().map_err(|_| InputError::new(path, &field, format!("'{w}' is not a number"))))
                .collect::<Result<Vec<f64>>>()?;
            if values.len() != 16 {
                return Err(InputError::new(path, &field, format!("expected 16 numbers (a row-major 4x4 pose), found {}", values.len())));
            }
            if values.iter().any(|v| !v.is_finite()) {
                return Err(InputError::new(path, &field, "pose holds a non-finite number"));
            }
            let pose = Matrix4::from_row_slice(&values);
            let bottom = [pose[(3, 0)], pose[(3, 1)], pose[(3, 2)], pose[(3, 3)]];
            if bottom.iter().zip([0.0, 0.0, 0.0, 1.0]).any(|(a, b)| (a - b).abs() > 1e-6) {
                return Err(InputError::new(path, &field, format!("last row must be 0 0 0 1 (a rigid camera-to-world transform), found {bottom:?}")));
            }
            poses.push(pose);
        }
        Ok(Self { poses })
    }

    /// The text HaDaGe writes: `%.18e ` for each value, one pose per line.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        for pose in &self.poses {
            for r in 0..4 {
                for c in 0..4 {
                    out.push_str(&printf_e18(pose[(r, c)]));
                    out.push(' ');
                }
            }
            out.push('\n');
        }
        out
    }

    /// Write `traj.txt`.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_text()).map_err(|e| InputError::io(path, &e))
    }
}

/// C's `%.18e` (`1.000000000000000000e+00`).
fn printf_e18(value: f64) -> String {
    let text = format!("{value:.18e}");
    let (mantissa, exponent) = text.split_once('e').expect("LowerExp has an exponent");
    format!("{mantissa}{}", c_exponent(exponent.parse().expect("integer exponent")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn printf_layout_matches_c() {
        assert_eq!(printf_e18(1.0), "1.000000000000000000e+00");
        assert_eq!(printf_e18(-0.25), "-2.500000000000000000e-01");
        assert_eq!(printf_e18(1234.5), "1.234500000000000000e+03");
    }
}
