//! The ghost exchange of a grid quantity between neighbouring slabs, in the substep's two directions:
//! after a scatter each rank's partial sums on its ghost planes go to their owner and are added
//! ([`sum_into_owners`]); after the grid update the owners' final values go back to the ghosts for the
//! gather ([`fill_ghosts`]).
//!
//! A rank's grid stores its slab and its ghost planes (`GridShape::planes`), its nodes named in the
//! domain's numbering: the physics (walls, band, colliders) reads their positions unchanged.

use super::comm::Comm;
use super::slabs::Slabs;
use crate::sim::cpu::GridShape;
use anyhow::Result;
use bytemuck::Pod;
use glam::Vec3;
use std::ops::Range;

/// A node value that ranks' partial sums add up to: float mass and momentum, or the fixed-point
/// scatter's integer units (whose sums do not depend on the order, so N ranks give one rank's bits).
pub trait NodeSum: Pod {
    fn add(&mut self, other: Self);
}

impl NodeSum for f32 {
    fn add(&mut self, other: f32) {
        *self += other;
    }
}

impl NodeSum for Vec3 {
    fn add(&mut self, other: Vec3) {
        *self += other;
    }
}

impl NodeSum for i64 {
    fn add(&mut self, other: i64) {
        *self += other;
    }
}

impl NodeSum for [i64; 3] {
    fn add(&mut self, other: [i64; 3]) {
        for (a, b) in self.iter_mut().zip(other) {
            *a += b;
        }
    }
}

/// The node indices of planes `planes` across the slab axis, in node order.
pub fn plane_nodes(shape: GridShape, axis: usize, planes: Range<u32>) -> Vec<usize> {
    let res = shape.res;
    let (a, b) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let mut nodes = Vec::with_capacity(planes.len() * (res[a] * res[b]) as usize);
    for i in 0..shape.num_nodes() {
        let node = shape.node(i);
        if planes.contains(&node[axis]) {
            nodes.push(i);
        }
    }
    nodes
}

/// Where one rank's ghost values meet its neighbours': the node lists of each transfer.
#[derive(Debug, Clone)]
pub struct HaloNodes {
    rank: usize,
    /// This rank's ghost planes below and above (owned by rank - 1 and rank + 1).
    low_ghost: Vec<usize>,
    high_ghost: Vec<usize>,
    /// This rank's own planes that are rank - 1's and rank + 1's ghosts.
    low_edge: Vec<usize>,
    high_edge: Vec<usize>,
    ranks: usize,
}

impl HaloNodes {
    pub fn new(slabs: &Slabs, shape: GridShape, rank: usize) -> HaloNodes {
        let planes = |range: Range<u32>| plane_nodes(shape, slabs.axis, range);
        let last = slabs.ranks() - 1;
        HaloNodes {
            rank,
            low_ghost: planes(slabs.low_ghost(rank)),
            high_ghost: planes(slabs.high_ghost(rank)),
            low_edge: if rank > 0 {
                planes(slabs.high_ghost(rank - 1))
            } else {
                Vec::new()
            },
            high_edge: if rank < last {
                planes(slabs.low_ghost(rank + 1))
            } else {
                Vec::new()
            },
            ranks: slabs.ranks(),
        }
    }

    /// The ghost planes' nodes, both sides.
    pub fn ghosts(&self) -> impl Iterator<Item = usize> + '_ {
        self.low_ghost.iter().chain(&self.high_ghost).copied()
    }

    fn below(&self) -> Option<usize> {
        self.rank.checked_sub(1)
    }

    fn above(&self) -> Option<usize> {
        (self.rank + 1 < self.ranks).then_some(self.rank + 1)
    }

    /// Sends the partial sums on this rank's ghost planes to their owners, zeroes them, and adds what
    /// the neighbours sent to this rank's own edge planes.
    pub fn sum_into_owners<T: NodeSum>(&self, comm: &mut dyn Comm, values: &mut [T]) -> Result<()> {
        let pick = |nodes: &[usize]| nodes.iter().map(|&i| values[i]).collect::<Vec<T>>();
        let (to_below, to_above) = (pick(&self.low_ghost), pick(&self.high_ghost));
        let mut from_below = vec![T::zeroed(); self.low_edge.len()];
        let mut from_above = vec![T::zeroed(); self.high_edge.len()];
        self.transfer(comm, (&to_below, &to_above), (&mut from_below, &mut from_above))?;
        for i in self.ghosts() {
            values[i] = T::zeroed();
        }
        for (nodes, got) in [(&self.low_edge, &from_below), (&self.high_edge, &from_above)] {
            for (&i, &v) in nodes.iter().zip(got.iter()) {
                values[i].add(v);
            }
        }
        Ok(())
    }

    /// Sends this rank's edge planes to the neighbours whose ghosts they are, and overwrites this
    /// rank's ghost planes with their owners' values.
    pub fn fill_ghosts<T: Pod>(&self, comm: &mut dyn Comm, values: &mut [T]) -> Result<()> {
        let pick = |nodes: &[usize]| nodes.iter().map(|&i| values[i]).collect::<Vec<T>>();
        let (to_below, to_above) = (pick(&self.low_edge), pick(&self.high_edge));
        let mut from_below = vec![T::zeroed(); self.low_ghost.len()];
        let mut from_above = vec![T::zeroed(); self.high_ghost.len()];
        self.transfer(comm, (&to_below, &to_above), (&mut from_below, &mut from_above))?;
        for (nodes, got) in [(&self.low_ghost, &from_below), (&self.high_ghost, &from_above)] {
            for (&i, &v) in nodes.iter().zip(got.iter()) {
                values[i] = v;
            }
        }
        Ok(())
    }

    /// One grouped exchange with both neighbours.
    fn transfer<T: Pod>(
        &self,
        comm: &mut dyn Comm,
        (to_below, to_above): (&[T], &[T]),
        (from_below, from_above): (&mut [T], &mut [T]),
    ) -> Result<()> {
        let mut sends = Vec::new();
        let mut recvs: Vec<(usize, &mut [u8])> = Vec::new();
        if let Some(below) = self.below() {
            sends.push((below, bytemuck::cast_slice(to_below)));
            recvs.push((below, bytemuck::cast_slice_mut(from_below)));
        }
        if let Some(above) = self.above() {
            sends.push((above, bytemuck::cast_slice(to_above)));
            recvs.push((above, bytemuck::cast_slice_mut(from_above)));
        }
        comm.exchange(&sends, &mut recvs)
    }
}
