//! Particles that left their rank's slab, moved to the rank that owns them now. Slot indices stay
//! stable within a rank: a leaving particle's slot is parked (as a drained particle's is) and an
//! arriving one takes the most recently parked slot, or a new one at the end.

use super::comm::{all_gather, all_sum, Comm};
use super::slabs::Slabs;
use crate::sim::{Deformation, Particles};
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Vec3};

/// One particle in flight, with the id that names it in a one-rank run.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Migrant {
    pub id: u32,
    pub rho: f32,
    /// Its row of the material table.
    pub material: u32,
    pub x: [f32; 3],
    pub v: [f32; 3],
    pub c: [f32; 9],
    /// Its deformation where the run carries one (`Particles::deformation`): F_E by columns, then
    /// the plastic scalar; zeros otherwise.
    pub f: [f32; 9],
    pub plastic: f32,
}
const _: () = assert!(std::mem::size_of::<Migrant>() == 112);

impl Migrant {
    /// Slot `i` of `p`, named `id`.
    pub fn of(p: &Particles, i: usize, id: u32) -> Migrant {
        let deformation = p.deformation.get(i);
        Migrant {
            id,
            rho: p.rho[i],
            material: u32::from(p.material[i]),
            x: p.x[i].to_array(),
            v: p.v[i].to_array(),
            c: p.c[i].to_cols_array(),
            f: deformation.map_or([0.0; 9], |d| d.f.to_cols_array()),
            plastic: deformation.map_or(0.0, |d| d.plastic),
        }
    }

    fn deformation(&self) -> Deformation {
        Deformation {
            f: Mat3::from_cols_array(&self.f),
            plastic: self.plastic,
        }
    }

    /// Writes it over slot `s` of `p`, live (its deformation where `p` carries them).
    pub fn place(&self, p: &mut Particles, s: usize) {
        (p.x[s], p.v[s], p.rho[s], p.live[s]) = (Vec3::from(self.x), Vec3::from(self.v), self.rho, true);
        p.c[s] = Mat3::from_cols_array(&self.c);
        p.material[s] = self.material as u8;
        if let Some(d) = p.deformation.get_mut(s) {
            *d = self.deformation();
        }
    }
}

/// A rank's particles: the slots, each live one's id, and the parked slots free for arrivals.
#[derive(Debug, Clone, Default)]
pub struct RankParticles {
    pub particles: Particles,
    pub id: Vec<u32>,
    /// Parked slots, the next to fill last.
    pub parked: Vec<u32>,
    /// Whether the run's particles carry a deformation: then `particles` has one per slot, even
    /// where the rank starts with none.
    pub deformed: bool,
}

/// What a migration moved, summed over the ranks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Migration {
    pub sent: u64,
    pub received: u64,
    /// Live particles on all ranks, before and after.
    pub live_before: u64,
    pub live_after: u64,
}

impl RankParticles {
    /// The particles of `all` (slot = id) that `slabs` gives to `rank`, in id order; parked slots of
    /// `all` go nowhere.
    pub fn share(all: &Particles, slabs: &Slabs, rank: usize, inv_dx: f32) -> RankParticles {
        let slots: Vec<usize> = (0..all.len())
            .filter(|&i| all.live[i] && slabs.owner(layer(all.x[i], slabs.axis, inv_dx)) == rank)
            .collect();
        RankParticles {
            particles: all.pick(&slots),
            id: slots.iter().map(|&slot| slot as u32).collect(),
            parked: Vec::new(),
            deformed: !all.deformation.is_empty(),
        }
    }

    /// Takes in `m`: the most recently parked slot, or a new one at the end.
    pub fn push(&mut self, m: &Migrant) {
        let p = &mut self.particles;
        match self.parked.pop() {
            Some(slot) => {
                m.place(p, slot as usize);
                self.id[slot as usize] = m.id;
            }
            None => {
                p.x.push(Vec3::from(m.x));
                p.v.push(Vec3::from(m.v));
                p.c.push(Mat3::from_cols_array(&m.c));
                p.rho.push(m.rho);
                p.material.push(m.material as u8);
                p.live.push(true);
                if self.deformed {
                    p.deformation.push(m.deformation());
                }
                self.id.push(m.id);
            }
        }
    }

    /// Sends every live particle whose block layer `slabs` gives to another rank there, and takes in
    /// the particles the other ranks send here. Every rank calls it together.
    pub fn migrate(&mut self, comm: &mut dyn Comm, slabs: &Slabs, inv_dx: f32) -> Result<Migration> {
        let (me, ranks) = (comm.rank(), comm.size());
        let live_before = self.particles.num_live() as u64;
        let mut leaving: Vec<Vec<Migrant>> = vec![Vec::new(); ranks];
        let p = &mut self.particles;
        for i in 0..p.len() {
            if !p.live[i] {
                continue;
            }
            let to = slabs.owner(layer(p.x[i], slabs.axis, inv_dx));
            if to != me {
                leaving[to].push(Migrant::of(p, i, self.id[i]));
                p.live[i] = false;
                self.parked.push(i as u32);
            }
        }
        // How many each rank sends each rank: row = sender.
        let counts: Vec<u64> = leaving.iter().map(|l| l.len() as u64).collect();
        let table = all_gather(comm, &counts)?;
        let mut arriving: Vec<Vec<Migrant>> = (0..ranks)
            .map(|from| vec![Migrant::zeroed(); table[from * ranks + me] as usize])
            .collect();
        let sends: Vec<(usize, &[u8])> = (0..ranks)
            .filter(|&to| to != me && !leaving[to].is_empty())
            .map(|to| (to, bytemuck::cast_slice(&leaving[to])))
            .collect();
        let mut recvs: Vec<(usize, &mut [u8])> = arriving
            .iter_mut()
            .enumerate()
            .filter(|(from, a)| *from != me && !a.is_empty())
            .map(|(from, a)| (from, bytemuck::cast_slice_mut(a.as_mut_slice())))
            .collect();
        comm.exchange(&sends, &mut recvs)?;
        let received: u64 = arriving.iter().map(|a| a.len() as u64).sum();
        // In sender order, each sender's in its slot order: the same slots every run.
        for m in arriving.iter().flatten() {
            self.push(m);
        }
        let sent = counts.iter().sum::<u64>();
        let live_after = self.particles.num_live() as u64;
        let total = all_sum(comm, &[sent, received, live_before, live_after])?;
        let migration = Migration {
            sent: total[0],
            received: total[1],
            live_before: total[2],
            live_after: total[3],
        };
        if migration.sent != migration.received || migration.live_before != migration.live_after {
            bail!(
                "particle migration lost or duplicated particles: {} sent, {} received, {} live before, {} after",
                migration.sent,
                migration.received,
                migration.live_before,
                migration.live_after
            );
        }
        Ok(migration)
    }
}

/// Live particles of `p` per block layer along `slabs.axis`.
pub fn layer_counts(p: &Particles, slabs: &Slabs, inv_dx: f32) -> Vec<u64> {
    let mut counts = vec![0u64; slabs.blocks() as usize];
    for i in (0..p.len()).filter(|&i| p.live[i]) {
        let l = layer(p.x[i], slabs.axis, inv_dx).min(slabs.blocks() - 1);
        counts[l as usize] += 1;
    }
    counts
}

/// The stencil base node of `x` along `axis`.
pub fn base(x: Vec3, axis: usize, inv_dx: f32) -> i32 {
    (x[axis] * inv_dx - 0.5).floor() as i32
}

/// The block layer of `x`'s stencil base along `axis`.
pub fn layer(x: Vec3, axis: usize, inv_dx: f32) -> u32 {
    Slabs::layer_of(base(x, axis, inv_dx))
}
