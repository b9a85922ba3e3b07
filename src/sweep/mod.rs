//! Parameter sweeps: one scene, several numbers of it swept over inclusive
//! ranges, one world per combination.
//!
//! ```text
//! worlds   = cartesian product of the axes, the last axis varying fastest:
//!            world w sets axis a to value(i_a), where
//!            w = Σ_a i_a · Π_{b > a} count_b
//! shard K/N (1-based) = worlds ⌊(K−1)·W/N⌋ … ⌊K·W/N⌋ − 1   (contiguous)
//! ```
//! Every world is the base scene document with its values written in
//! ([`FieldPath::set`]) and then parsed and validated like a scene file, so
//! a bad value is refused with the world and the field named. A world runs
//! exactly as the scene file with those values would on its own: the
//! shards of a sweep, concatenated in order, are the whole sweep.

mod axis;
mod field_path;
mod metric;

pub use axis::SweepAxis;
pub use field_path::{FieldPath, Segment};
pub use metric::Metric;

use crate::{Scene, SceneError};
use serde_json::Value;
use std::ops::Range;
use std::str::FromStr;

/// Why a sweep cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The base document is not a scene.
    #[error("{0}")]
    Base(#[source] SceneError),
    /// A path that does not lead to a number of the scene.
    #[error("--set {path}: {why}")]
    Path { path: String, why: String },
    /// A world whose values make an invalid scene.
    #[error("worlds[{world}] ({settings}): {source}")]
    World {
        world: usize,
        settings: String,
        #[source]
        source: SceneError,
    },
    /// More worlds than can be counted.
    #[error("the sweep has more worlds than fit in a usize")]
    TooManyWorlds,
}

/// A scene and the axes swept over it.
#[derive(Debug, Clone)]
pub struct Sweep {
    base: Value,
    dim: usize,
    axes: Vec<SweepAxis>,
    worlds: usize,
}

impl Sweep {
    /// A sweep of the scene document `text` (validated as a scene first)
    /// over `axes`. Every axis path is checked on the base scene.
    pub fn new(text: &str, axes: Vec<SweepAxis>) -> Result<Sweep, SweepError> {
        let scene = Scene::from_json_str(text).map_err(SweepError::Base)?;
        let base = serde_json::from_str(text).map_err(|e| {
            SweepError::Base(SceneError::Json {
                path: "(document)".into(),
                message: e.to_string(),
            })
        })?;
        let worlds = axes
            .iter()
            .try_fold(1usize, |w, a| w.checked_mul(a.count))
            .ok_or(SweepError::TooManyWorlds)?;
        let sweep = Sweep {
            base,
            dim: scene.dim,
            axes,
            worlds,
        };
        for axis in &sweep.axes {
            axis.path.set(&mut sweep.base.clone(), sweep.dim, axis.lo)?;
        }
        Ok(sweep)
    }

    /// The swept axes.
    pub fn axes(&self) -> &[SweepAxis] {
        &self.axes
    }

    /// Number of worlds (product of the axis counts; 1 without axes).
    pub fn world_count(&self) -> usize {
        self.worlds
    }

    /// The (path, value) pairs of world `world`, in axis order.
    pub fn settings(&self, world: usize) -> Vec<(&FieldPath, f64)> {
        let mut rest = world;
        let mut out: Vec<(&FieldPath, f64)> = self
            .axes
            .iter()
            .rev()
            .map(|axis| {
                let k = rest % axis.count;
                rest /= axis.count;
                (&axis.path, axis.value(k))
            })
            .collect();
        out.reverse();
        out
    }

    /// The scene document of world `world` (base with its values set).
    pub fn document(&self, world: usize) -> Result<Value, SweepError> {
        let mut document = self.base.clone();
        for (path, value) in self.settings(world) {
            path.set(&mut document, self.dim, value)?;
        }
        Ok(document)
    }

    /// The validated scene of world `world`.
    pub fn scene(&self, world: usize) -> Result<Scene, SweepError> {
        let text = self.document(world)?.to_string();
        Scene::from_json_str(&text).map_err(|source| SweepError::World {
            world,
            settings: self
                .settings(world)
                .iter()
                .map(|(p, v)| format!("{p}={v}"))
                .collect::<Vec<_>>()
                .join(", "),
            source,
        })
    }
}

/// `--shard K/N`: the K-th (1-based) of N contiguous slices of the worlds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 1-based slice number.
    pub index: usize,
    /// Number of slices.
    pub count: usize,
}

impl Shard {
    /// The whole sweep.
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// The worlds of this slice of `worlds` (see the module docs).
    pub fn range(self, worlds: usize) -> Range<usize> {
        let bound = |k: usize| (k as u128 * worlds as u128 / self.count as u128) as usize;
        bound(self.index - 1)..bound(self.index)
    }
}

impl FromStr for Shard {
    type Err = String;

    fn from_str(text: &str) -> Result<Shard, String> {
        let bad = || format!("--shard {text}: expected K/N with 1 ≤ K ≤ N");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}
