//! Which rank owns which part of the grid: slabs of whole 4x4x4-node blocks along the domain's
//! longest axis, their ghost planes, and where the bounds go to balance the particle counts.

use anyhow::{bail, Result};
use glam::UVec3;
use std::ops::{Range, RangeInclusive};

/// The edge of a node block, nodes: the unit slabs are cut in, and the depth of each ghost layer.
pub const BLOCK: u32 = 4;

/// The fewest blocks a slab holds: its two ghost layers' owners must be its direct neighbours, and
/// the walls' mirror pairs (`sim::cpu::mirror_walls`, a few nodes deep) must stay inside the end
/// slabs.
pub const MIN_SLAB_BLOCKS: u32 = 2;

/// The busiest rank may hold this much above the mean particle count before the bounds move.
pub const BALANCE_TOLERANCE: f64 = 0.10;

/// The grid cut into one slab per rank along `axis`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Slabs {
    /// The axis the slabs are cut across: the grid's longest (x before y before z on a tie).
    pub axis: usize,
    /// Nodes along `axis`.
    pub nodes: u32,
    /// Block layers: rank r owns blocks `bounds[r]..bounds[r + 1]` along `axis`.
    pub bounds: Vec<u32>,
}

impl Slabs {
    /// Equal slabs (to a block) for `ranks` ranks on a grid of `res` nodes.
    pub fn even(res: UVec3, ranks: usize) -> Result<Slabs> {
        let (axis, nodes) = longest_axis(res);
        let blocks = nodes.div_ceil(BLOCK);
        check_fits(axis, blocks, ranks)?;
        let bounds = (0..=ranks)
            .map(|r| (u64::from(blocks) * r as u64 / ranks as u64) as u32)
            .collect();
        Ok(Slabs { axis, nodes, bounds })
    }

    /// Slabs that split `per_layer` (particles per block layer along the axis, as [`Slabs::layer_counts`]
    /// counts them) as evenly as whole layers allow, each at least [`MIN_SLAB_BLOCKS`] thick.
    /// Deterministic: every rank computes the same bounds from the same counts.
    pub fn balanced(&self, per_layer: &[u64]) -> Result<Slabs> {
        let ranks = self.ranks();
        let blocks = per_layer.len() as u32;
        check_fits(self.axis, blocks, ranks)?;
        let total: u64 = per_layer.iter().sum();
        let mut bounds = vec![0u32];
        let (mut layer, mut below) = (0u32, 0u64);
        for r in 1..ranks {
            // The first layer boundary at or past this rank's share, leaving room for the rest.
            let target = total * r as u64 / ranks as u64;
            let lowest = bounds[r - 1] + MIN_SLAB_BLOCKS;
            let highest = blocks - MIN_SLAB_BLOCKS * (ranks - r) as u32;
            // Layers go below the bound while at least half of the next one still fits under the
            // target: the bound nearest the even split.
            while layer < highest && (layer < lowest || 2 * below + per_layer[layer as usize] <= 2 * target) {
                below += per_layer[layer as usize];
                layer += 1;
            }
            bounds.push(layer);
        }
        bounds.push(blocks);
        Ok(Slabs {
            axis: self.axis,
            nodes: self.nodes,
            bounds,
        })
    }

    pub fn ranks(&self) -> usize {
        self.bounds.len() - 1
    }

    /// Block layers along the axis.
    pub fn blocks(&self) -> u32 {
        *self.bounds.last().unwrap_or(&0)
    }

    /// The block layer of a particle's stencil base node `base` (a node index along the axis).
    pub fn layer_of(base: i32) -> u32 {
        (base.max(0) as u32) / BLOCK
    }

    /// The rank whose slab holds block layer `layer`.
    pub fn owner(&self, layer: u32) -> usize {
        let layer = layer.min(self.blocks().saturating_sub(1));
        self.bounds[1..].partition_point(|&end| end <= layer)
    }

    /// The node planes rank `rank` owns along the axis.
    pub fn owned(&self, rank: usize) -> Range<u32> {
        let node = |b: u32| (b * BLOCK).min(self.nodes);
        node(self.bounds[rank])..node(self.bounds[rank + 1])
    }

    /// The ghost planes below the slab (the lower neighbour's last block), none for rank 0.
    pub fn low_ghost(&self, rank: usize) -> Range<u32> {
        let lo = self.owned(rank).start;
        if rank == 0 {
            lo..lo
        } else {
            lo - BLOCK..lo
        }
    }

    /// The ghost planes above the slab (the upper neighbour's first block), none for the last rank.
    pub fn high_ghost(&self, rank: usize) -> Range<u32> {
        let hi = self.owned(rank).end;
        if rank + 1 == self.ranks() {
            hi..hi
        } else {
            hi..(hi + BLOCK).min(self.nodes)
        }
    }

    /// The planes `rank` touches: its slab and ghost planes, which its grid holds.
    pub fn held(&self, rank: usize) -> Range<u32> {
        self.low_ghost(rank).start..self.high_ghost(rank).end
    }

    /// Whether a particle of `rank` with stencil base node `base` (along the axis) can take one more
    /// substep without migrating: its stencil, one cell further either way, stays inside the slab and
    /// its ghost planes.
    pub fn keeps(&self, rank: usize, base: i32) -> bool {
        self.kept_bases(rank).contains(&base)
    }

    /// The stencil bases [`Slabs::keeps`] keeps on `rank`: after a move of one cell the stencil
    /// covers nodes base - 1 ..= base + 3, which must lie in the slab and its ghost planes (the end
    /// ranks keep anything beyond the domain's ends).
    pub fn kept_bases(&self, rank: usize) -> RangeInclusive<i32> {
        let low = if rank == 0 {
            i32::MIN
        } else {
            self.low_ghost(rank).start as i32 + 1
        };
        let high = if rank + 1 == self.ranks() {
            i32::MAX
        } else {
            self.high_ghost(rank).end as i32 - 4
        };
        low..=high
    }

    /// Whether the walls' mirror pairs along the slab axis (`sim::cpu::mirror_walls`: nodes
    /// `wall - d` and `wall + d`) lie inside the end slabs, so each end rank mirrors its own wall.
    pub fn holds_mirror(&self, wall_lo: u32, wall_hi: u32) -> bool {
        let reach = |wall: u32| wall.min(self.nodes - 1 - wall);
        wall_lo == 0
            || (wall_lo + reach(wall_lo) < self.owned(0).end
                && wall_hi - reach(wall_hi) >= self.owned(self.ranks() - 1).start)
    }

    /// At a rebin: the slabs [`Slabs::balanced`] for `per_layer`, where the counts are out of balance
    /// and the move lowers the busiest rank's count and keeps the walls' mirror pairs (`walls`: low
    /// and high plane along the axis) in the end slabs; `None` keeps these.
    pub fn rebalanced(&self, per_layer: &[u64], (wall_lo, wall_hi): (u32, u32)) -> Result<Option<Slabs>> {
        let now = self.rank_counts(per_layer);
        if !Slabs::unbalanced(&now) {
            return Ok(None);
        }
        let balanced = self.balanced(per_layer)?;
        let busiest = |counts: Vec<u64>| counts.into_iter().max().unwrap_or(0);
        let better = busiest(balanced.rank_counts(per_layer)) < busiest(now);
        Ok((better && balanced.holds_mirror(wall_lo, wall_hi)).then_some(balanced))
    }

    /// Whether the busiest count in `per_rank` lies more than [`BALANCE_TOLERANCE`] above the mean.
    pub fn unbalanced(per_rank: &[u64]) -> bool {
        let total: u64 = per_rank.iter().sum();
        let busiest = per_rank.iter().copied().max().unwrap_or(0);
        total > 0 && busiest as f64 > (1.0 + BALANCE_TOLERANCE) * total as f64 / per_rank.len() as f64
    }

    /// Particles per rank, from the particles per block layer.
    pub fn rank_counts(&self, per_layer: &[u64]) -> Vec<u64> {
        (0..self.ranks())
            .map(|r| {
                per_layer[self.bounds[r] as usize..self.bounds[r + 1] as usize]
                    .iter()
                    .sum()
            })
            .collect()
    }
}

/// The axis with the most nodes (the first of equals) and its node count.
pub fn longest_axis(res: UVec3) -> (usize, u32) {
    (0..3).fold(
        (0, res.x),
        |(a, n), b| if res[b] > n { (b, res[b]) } else { (a, n) },
    )
}

fn check_fits(axis: usize, blocks: u32, ranks: usize) -> Result<()> {
    if ranks == 0 {
        bail!("the run needs at least one rank");
    }
    let most = (blocks / MIN_SLAB_BLOCKS).max(1) as usize;
    if ranks > most {
        bail!(
            "{ranks} ranks do not fit: the grid's longest axis ({}) holds {blocks} blocks of {BLOCK} nodes \
             and each rank needs at least {MIN_SLAB_BLOCKS}, so at most {most} ranks; use fewer ranks \
             or a finer grid",
            ["x", "y", "z"][axis]
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn even_slabs_cover_the_longest_axis_in_whole_blocks() {
        let s = Slabs::even(UVec3::new(40, 100, 30), 3).unwrap();
        assert_eq!(s.axis, 1);
        assert_eq!(s.bounds, vec![0, 8, 16, 25]);
        assert_eq!(s.owned(0), 0..32);
        assert_eq!(s.owned(2), 64..100);
        assert_eq!(s.low_ghost(0), 0..0);
        assert_eq!(s.low_ghost(1), 28..32);
        assert_eq!(s.high_ghost(1), 64..68);
        assert_eq!(s.high_ghost(2), 100..100);
        assert_eq!((s.held(0), s.held(1), s.held(2)), (0..36, 28..68, 60..100));
        assert_eq!(
            (s.owner(0), s.owner(7), s.owner(8), s.owner(24), s.owner(99)),
            (0, 0, 1, 2, 2)
        );
    }

    #[test]
    fn too_many_ranks_is_an_error_naming_the_limit() {
        let err = Slabs::even(UVec3::new(16, 12, 12), 3).unwrap_err().to_string();
        assert!(err.contains("at most 2 ranks"), "{err}");
    }

    #[test]
    fn balancing_splits_the_particles_and_keeps_slabs_thick_enough() {
        let s = Slabs::even(UVec3::new(64, 16, 16), 2).unwrap();
        // All particles in the first 4 layers of 16.
        let mut per_layer = vec![0u64; 16];
        per_layer[..4].fill(100);
        assert!(Slabs::unbalanced(&s.rank_counts(&per_layer)));
        let b = s.balanced(&per_layer).unwrap();
        assert_eq!(b.bounds, vec![0, 2, 16]);
        assert_eq!(b.rank_counts(&per_layer), vec![200, 200]);
        assert!(!Slabs::unbalanced(&b.rank_counts(&per_layer)));
        // Crowded at the top: the minimum thickness holds on the way.
        let mut top = vec![0u64; 16];
        top[15] = 1000;
        let b = Slabs::even(UVec3::new(64, 16, 16), 3)
            .unwrap()
            .balanced(&top)
            .unwrap();
        assert_eq!(b.bounds, vec![0, 12, 14, 16]);
    }

    #[test]
    fn a_particle_stays_while_its_stencil_and_one_more_cell_fit_the_ghosts() {
        let s = Slabs::even(UVec3::new(64, 16, 16), 2).unwrap(); // rank 0: 0..32, ghost 32..36
        assert!(s.keeps(0, 0) && s.keeps(0, 32));
        assert!(!s.keeps(0, 33));
        assert!(s.keeps(1, 29) && !s.keeps(1, 28)); // rank 1: ghost 28..32
        assert!(s.keeps(1, 62));
    }
}
