//! Where the time of one mesh voxelization goes: named stages with wall and CPU seconds
//! (`volga bench voxelize --profile`, the profile in `docs/VOXELIZE.md`).

use std::time::Instant;

/// One stage of a voxelization.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ProfileStage {
    /// Stage name (stable: benchmarks and docs quote them).
    pub name: &'static str,
    /// Wall seconds of the stage. For the parts of the parallel brick loop (`distances`,
    /// `band_signs`, `flood_signs`, `brick_output`) the loop's wall time is shared out
    /// in proportion to their CPU time, so the stages' wall times add up to the call's.
    pub wall_s: f64,
    /// CPU seconds summed over the threads that worked on the stage.
    pub cpu_s: f64,
}

/// The stages of one voxelization, in the order they ran.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct VoxelizeProfile {
    /// Stages in order; a stage a mode does not need is absent.
    pub stages: Vec<ProfileStage>,
}

impl VoxelizeProfile {
    /// Appends a stage.
    pub fn push(&mut self, name: &'static str, wall_s: f64, cpu_s: f64) {
        self.stages.push(ProfileStage { name, wall_s, cpu_s });
    }

    /// Appends a serial stage that started at `start` (its CPU time is its wall time).
    pub(crate) fn serial(&mut self, name: &'static str, start: Instant) -> Instant {
        let now = Instant::now();
        let wall = (now - start).as_secs_f64();
        self.push(name, wall, wall);
        now
    }

    /// Appends the stages of `other` after these.
    pub fn extend(&mut self, other: &VoxelizeProfile) {
        self.stages.extend(other.stages.iter().cloned());
    }

    /// Total wall seconds.
    pub fn wall_s(&self) -> f64 {
        self.stages.iter().map(|s| s.wall_s).sum()
    }
}

/// CPU seconds of the parts of one brick's work, summed over bricks.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct BrickClock {
    pub(crate) distances: f64,
    pub(crate) band_signs: f64,
    pub(crate) flood_signs: f64,
    pub(crate) output: f64,
}

impl BrickClock {
    pub(crate) fn add(&mut self, other: &BrickClock) {
        self.distances += other.distances;
        self.band_signs += other.band_signs;
        self.flood_signs += other.flood_signs;
        self.output += other.output;
    }

    /// The four parts as stages sharing out `wall` seconds.
    pub(crate) fn stages(&self, wall: f64, profile: &mut VoxelizeProfile) {
        let parts = [
            ("distances", self.distances),
            ("band_signs", self.band_signs),
            ("flood_signs", self.flood_signs),
            ("brick_output", self.output),
        ];
        let cpu: f64 = parts.iter().map(|p| p.1).sum();
        for (name, c) in parts {
            let share = if cpu > 0.0 { wall * c / cpu } else { 0.0 };
            profile.push(name, share, c);
        }
    }
}

/// A lap timer that costs nothing when off.
pub(crate) struct Lap(Option<Instant>);

impl Lap {
    pub(crate) fn new(on: bool) -> Lap {
        Lap(on.then(Instant::now))
    }

    /// Seconds since the last lap (0 when off), and starts the next.
    pub(crate) fn lap(&mut self) -> f64 {
        match &mut self.0 {
            Some(start) => {
                let now = Instant::now();
                let s = (now - *start).as_secs_f64();
                *start = now;
                s
            }
            None => 0.0,
        }
    }
}
