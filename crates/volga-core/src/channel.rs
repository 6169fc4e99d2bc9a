//! What a voxel channel holds.

use std::fmt;

/// The meaning of the values of a voxel channel, stored with the volume so exporters,
/// the validator and renderers can tell a distance field from occupancy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ChannelKind {
    /// Density (occupancy) in \[0, 1\], anti-aliased: ½ on the surface, rising inwards.
    Density,
    /// Signed distance in world units, negative inside (or unsigned, ≥ 0, when the
    /// producer had no inside); clamped to a narrow band, background = the band.
    SignedDistance,
    /// Binary occupancy: exactly 0 or 1.
    Binary,
    /// Linear RGB colour, each component in \[0, 1\].
    Colour,
}

impl ChannelKind {
    /// A short lowercase name (`density`, `signed-distance`, `binary`, `colour`).
    pub fn name(self) -> &'static str {
        match self {
            ChannelKind::Density => "density",
            ChannelKind::SignedDistance => "signed-distance",
            ChannelKind::Binary => "binary",
            ChannelKind::Colour => "colour",
        }
    }
}

impl fmt::Display for ChannelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
