//! What ranks start from: the run's every slot, held whole ([`Particles`]), a scene's spawn
//! walked again for each question and never held ([`Spawn`]), or a checkpoint's particles read from
//! its file for each question (`checkpoint::ParticlesInFile`). A process of one rank
//! (`--processes`) starts from the spawn or the file, so its host holds its own share of the
//! particles, not the run's: a billion particles as two processes of one host no longer need the
//! run twice in host memory at start.

use super::migrate::{layer, layer_counts, RankParticles};
use super::slabs::Slabs;
use crate::sim::{Particles, Scene};
use anyhow::Result;

/// A run's particles as its ranks are made from them.
pub trait Start {
    /// The run's slots: ids run over them.
    fn slots(&self) -> usize;
    /// Its live particles.
    fn live(&self) -> u64;
    /// Live particles per block layer along `slabs.axis`.
    fn layer_counts(&self, slabs: &Slabs, inv_dx: f32) -> Result<Vec<u64>>;
    /// The live particles `slabs` gives to `rank`, in id order.
    fn share(&self, slabs: &Slabs, rank: usize, inv_dx: f32) -> Result<RankParticles>;
}

impl Start for Particles {
    fn slots(&self) -> usize {
        self.len()
    }

    fn live(&self) -> u64 {
        self.num_live() as u64
    }

    fn layer_counts(&self, slabs: &Slabs, inv_dx: f32) -> Result<Vec<u64>> {
        Ok(layer_counts(self, slabs, inv_dx))
    }

    fn share(&self, slabs: &Slabs, rank: usize, inv_dx: f32) -> Result<RankParticles> {
        Ok(RankParticles::share(self, slabs, rank, inv_dx))
    }
}

/// A scene's start, spawned again for each question (`Scene::each_spawned`): the same particles in
/// the same slots as `Scene::spawn`, of which only a rank's share is ever held.
pub struct Spawn<'a> {
    scene: &'a Scene,
}

impl<'a> Spawn<'a> {
    pub fn new(scene: &'a Scene) -> Spawn<'a> {
        Spawn { scene }
    }
}

impl Start for Spawn<'_> {
    fn slots(&self) -> usize {
        self.scene.slots()
    }

    fn live(&self) -> u64 {
        self.scene.num_particles as u64
    }

    fn layer_counts(&self, slabs: &Slabs, inv_dx: f32) -> Result<Vec<u64>> {
        let mut counts = vec![0u64; slabs.blocks() as usize];
        self.scene.each_spawned(|_, p| {
            let l = layer(p.x, slabs.axis, inv_dx).min(slabs.blocks() - 1);
            counts[l as usize] += 1;
        });
        Ok(counts)
    }

    fn share(&self, slabs: &Slabs, rank: usize, inv_dx: f32) -> Result<RankParticles> {
        let scene = self.scene;
        let mut mine = RankParticles::default();
        let (p, id) = (&mut mine.particles, &mut mine.id);
        scene.each_spawned(|slot, s| {
            if slabs.owner(layer(s.x, slabs.axis, inv_dx)) == rank {
                p.push_spawned(s);
                id.push(slot as u32);
            }
        });
        let n = id.len();
        (p.c, p.live) = (vec![glam::Mat3::ZERO; n], vec![true; n]);
        if scene.has_deformation() {
            p.deformation = p.material.iter().map(|&row| scene.at_rest(row)).collect();
            mine.deformed = true;
        }
        Ok(mine)
    }
}

/// Asserts that `start` answers every question a run of `ranks` ranks of `scene` asks as `whole`
/// (the same run's particles, held) answers it: slots, live particles, the slabs cut, each slab
/// layer's count, and each rank's share, ids and particles; the shares together hold every live
/// particle.
#[cfg(test)]
pub(crate) fn assert_answers_as_whole(scene: &Scene, start: &dyn Start, whole: &Particles, ranks: usize) {
    let inv_dx = scene.params().inv_dx;
    let slabs = super::starting_slabs(scene, whole, ranks).unwrap();
    assert_eq!(start.slots(), whole.slots());
    assert_eq!(start.live(), whole.live());
    assert_eq!(
        start.layer_counts(&slabs, inv_dx).unwrap(),
        whole.layer_counts(&slabs, inv_dx).unwrap()
    );
    assert_eq!(super::starting_slabs(scene, start, ranks).unwrap(), slabs);
    let mut held = 0;
    for rank in 0..ranks {
        let (a, b) = (
            start.share(&slabs, rank, inv_dx).unwrap(),
            whole.share(&slabs, rank, inv_dx).unwrap(),
        );
        assert_eq!(a.id, b.id, "rank {rank}'s ids");
        assert!(a.particles == b.particles, "rank {rank}'s particles");
        held += a.id.len();
    }
    assert_eq!(held as u64, whole.live());
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spawn walked rank by rank gives each rank what the whole spawn's share gives it, and the
    /// same layer counts: a tank with two overlapping bodies (the second skips the first's points)
    /// and a collider the particles avoid.
    #[test]
    fn a_spawn_s_shares_are_the_whole_spawn_s() {
        let scene = Scene::from_toml(
            r#"
            [domain]
            size = [1.0, 0.6, 0.4]
            resolution = [40, 24, 16]
            [material]
            rest_density = 1000.0
            sound_speed = 10.0
            [[block]]
            min = [0.05, 0.05, 0.05]
            max = [0.45, 0.30, 0.35]
            [[block]]
            min = [0.30, 0.05, 0.05]
            max = [0.90, 0.20, 0.35]
            velocity = [0.5, 0.0, 0.0]
            [[collider]]
            shape = "box"
            center = [0.6, 0.1, 0.2]
            size = [0.1, 0.1, 0.1]
            boundary = "slip"
            "#,
            "shares.toml",
        )
        .unwrap();
        assert_answers_as_whole(&scene, &Spawn::new(&scene), &scene.spawn(), 3);
    }
}
