//! The classification slot of volume rendering: what maps a sample to colour and
//! opacity. Today's only classifier is the 1D transfer function applied after
//! interpolation (post-classification, survey eq. 15); a 2D (value × gradient
//! magnitude) or pre-integrated transfer function comes in as another
//! [`Classify`] implementation and [`Classifier`] variant, without touching the
//! compositing loop of [`Volume`](crate::Volume).

use glam::{DVec3, Vec4};

use crate::TransferFunction;

/// What a classifier sees of one sample on the ray lattice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClassifySample {
    /// The reconstructed value at the sample (never NaN: NaN samples are dropped).
    pub value: f64,
    /// The value at the previous lattice sample of the same ray (the front end of
    /// the ray segment ending here, what pre-integration needs); NaN at the first
    /// sample, after a NaN sample and after a skipped macro cell.
    pub previous_value: f64,
    /// World position of the sample.
    pub world_pos: DVec3,
}

/// Maps samples to straight (un-premultiplied) RGBA in \[0, 1\], the opacity
/// defined for [`Sampling::reference_step_voxels`](crate::Sampling::reference_step_voxels)
/// (the compositing loop corrects it for the actual step).
pub trait Classify: Sync {
    /// RGBA of the sample.
    fn classify(&self, sample: &ClassifySample) -> Vec4;

    /// A conservative maximum of the opacity over values in `[lo, hi]`: `0` only
    /// if every sample with a value in range is transparent. Empty-space skipping
    /// skips cells where it is `0`.
    fn max_alpha(&self, lo: f64, hi: f64) -> f32;
}

impl Classify for TransferFunction {
    /// Post-classification: the transfer function at the interpolated value.
    #[inline]
    fn classify(&self, sample: &ClassifySample) -> Vec4 {
        self.eval(sample.value)
    }

    fn max_alpha(&self, lo: f64, hi: f64) -> f32 {
        TransferFunction::max_alpha(self, lo, hi)
    }
}

/// The classifiers volume rendering can use (dispatched once per ray, so the
/// compositing loop is monomorphized per classifier).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Classifier {
    /// A 1D transfer function, post-classified (survey eq. 15).
    Transfer(TransferFunction),
}

impl Classifier {
    /// See [`Classify::max_alpha`].
    pub fn max_alpha(&self, lo: f64, hi: f64) -> f32 {
        match self {
            Classifier::Transfer(tf) => tf.max_alpha(lo, hi),
        }
    }
}

impl From<TransferFunction> for Classifier {
    fn from(tf: TransferFunction) -> Self {
        Classifier::Transfer(tf)
    }
}
