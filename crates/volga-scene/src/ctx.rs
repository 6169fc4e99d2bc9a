//! The validation context: every check names the field path of the value it refuses.

use std::path::Path;

use glam::DVec3;

use crate::model::V3;
use crate::SceneError;

/// The scene file being validated; checks return errors naming it and a field path.
pub struct Ctx<'a> {
    pub path: &'a Path,
}

impl Ctx<'_> {
    pub fn err(&self, field: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_owned(),
            field: field.into(),
            message: message.into(),
        }
    }

    pub fn finite3(&self, field: &str, v: V3) -> Result<DVec3, SceneError> {
        let d = DVec3::from_array(v);
        if d.is_finite() {
            Ok(d)
        } else {
            Err(self.err(field, format!("must be finite, got {v:?}")))
        }
    }

    pub fn nonzero3(&self, field: &str, v: V3) -> Result<DVec3, SceneError> {
        let d = self.finite3(field, v)?;
        if d == DVec3::ZERO {
            return Err(self.err(field, "must not be the zero vector"));
        }
        Ok(d)
    }

    pub fn positive(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(field, format!("must be finite and > 0, got {v}")))
        }
    }

    pub fn unit_interval(&self, field: &str, v: &[f64]) -> Result<(), SceneError> {
        if v.iter().all(|x| (0.0..=1.0).contains(x)) {
            Ok(())
        } else {
            Err(self.err(field, format!("components must lie in [0, 1], got {v:?}")))
        }
    }

    /// A colour in \[0, 1\]³, white when absent.
    pub fn colour(&self, field: &str, c: Option<V3>) -> Result<volga_core::Rgb, SceneError> {
        match c {
            Some(c) => {
                self.unit_interval(field, &c)?;
                Ok(c.map(|x| x as f32))
            }
            None => Ok([1.0; 3]),
        }
    }

    pub fn file_stem(&self, field: &str, name: &str) -> Result<(), SceneError> {
        let ok = !name.is_empty()
            && name.len() <= 100
            && !name.starts_with('.')
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if ok {
            Ok(())
        } else {
            Err(self.err(
                field,
                format!("`{name}` is not a valid file name (letters, digits, `_`, `-`, `.`; not starting with `.`)"),
            ))
        }
    }
}
