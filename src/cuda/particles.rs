//! The particle state on the device, structure of arrays: what the kernels read and write every
//! substep. Each particle carries its slot (its index as users see it), because the fused pipeline
//! stores the particles in bin order, moving them in memory at each binning (bin_order.rs); readers
//! get them back in slot order (`download`).

use super::gpu::Gpu;
use crate::contract::PARKED_W;
use crate::sim::{Deformation, Particles};
use anyhow::{bail, ensure, Context, Result};
use cudarc::driver::{CudaSlice, CudaStream, DevicePtr};
use glam::{Mat3, Vec3};
use std::ops::Range;
use std::sync::Arc;

/// Bytes of one particle's state: x, v as float4; C as 3 float4; rho; its slot.
pub const STATE_BYTES_PER_PARTICLE: usize = 4 * (4 + 4 + 12 + 1 + 1);
/// Bytes of one particle's deformation, where a material carries one: F_E as 3 float4 columns, the
/// plastic scalar in the first column's w.
pub const DEFORMATION_BYTES_PER_PARTICLE: usize = 4 * 12;
/// Bytes of one particle's state on the device, its deformation where `deformed`: what each set of
/// particles (the one stepped, the bin-order gather's spare) takes a particle.
pub fn state_bytes(deformed: bool) -> usize {
    STATE_BYTES_PER_PARTICLE
        + if deformed {
            DEFORMATION_BYTES_PER_PARTICLE
        } else {
            0
        }
}
/// Bytes on the device a particle takes, its deformation where `deformed`: its state and the bins'
/// order, key and rank ([`BYTES_PER_PARTICLE`] with the deformation).
pub fn device_bytes(deformed: bool) -> usize {
    BYTES_PER_PARTICLE - STATE_BYTES_PER_PARTICLE + state_bytes(deformed)
}
/// The slot of a place a rank's buffers grew by, which holds no particle of the run (no reader
/// looks at a parked place's slot).
pub const NO_SLOT: u32 = u32::MAX;
/// Places [`DeviceParticles::place_live_into`] reads at a time: about 23 MB staged on the host (35
/// with a deformation), a piece's copies a few milliseconds.
pub const READ_PIECE: usize = 1 << 18;
/// Bytes on the device per particle: its state and the bins' order, key and rank (bins.rs).
pub const BYTES_PER_PARTICLE: usize = STATE_BYTES_PER_PARTICLE + 4 * 3;

pub struct DeviceParticles {
    pub count: usize,
    /// x, y, z, and w: 0 for a live particle, PARKED_W for a parked slot. One float4 per particle (a
    /// layout a GL vertex buffer can share).
    pub x: CudaSlice<f32>,
    /// vx, vy, vz, and w: the bits of the particle's material row (0.0 for row 0).
    pub v: CudaSlice<f32>,
    /// C as three float4 arrays of `count` (columns 0, 1, 2).
    pub c: CudaSlice<f32>,
    /// The density p2g estimated (per particle, from the grid's mass).
    pub rho: CudaSlice<f32>,
    /// Per place in memory, the slot of the particle stored there: the identity until the fused
    /// pipeline first gathers the particles into bin order.
    pub slot: CudaSlice<u32>,
    /// Where a material carries a deformation (`Params::has_deformation`), each particle's
    /// deformation as three float4 arrays of `count` (F_E's columns 0, 1, 2; column 0's w the
    /// plastic scalar); `None` otherwise: a scene of liquids holds nothing more than it did before
    /// the solids.
    pub deformation: Option<CudaSlice<f32>>,
}

impl DeviceParticles {
    /// Zeroed buffers for `count` particles, each stored at its slot, with their deformation where
    /// `deformed`.
    pub fn allocate(stream: &Arc<CudaStream>, count: usize, deformed: bool) -> Result<DeviceParticles> {
        let alloc = |len: usize, what: &str| {
            stream
                .alloc_zeros::<f32>(len)
                .with_context(|| format!("allocating {what} ({len} floats)"))
        };
        Ok(DeviceParticles {
            count,
            x: alloc(4 * count, "particle positions")?,
            v: alloc(4 * count, "particle velocities")?,
            c: alloc(12 * count, "particle affine matrices")?,
            rho: alloc(count, "particle densities")?,
            slot: stream
                .clone_htod(&slots_in_place(count))
                .context("allocating the particle slots")?,
            deformation: match deformed {
                true => Some(alloc(12 * count, "particle deformation gradients")?),
                false => None,
            },
        })
    }

    /// Copies `particles` (every slot, parked ones marked) into the buffers, each at its slot, and
    /// waits.
    pub fn upload(&mut self, stream: &Arc<CudaStream>, particles: &Particles) -> Result<()> {
        let n = particles.len();
        ensure!(n == self.count, "{n} particles for a solver of {}", self.count);
        let velocities: Vec<f32> = particles
            .v
            .iter()
            .zip(&particles.material)
            .flat_map(|(v, &material)| [v.x, v.y, v.z, material_tag(material)])
            .collect();
        let positions: Vec<f32> = particles
            .x
            .iter()
            .zip(&particles.live)
            .flat_map(|(p, &live)| [p.x, p.y, p.z, if live { 0.0 } else { PARKED_W }])
            .collect();
        let mut c = Vec::with_capacity(12 * n);
        for col in 0..3 {
            c.extend(particles.c.iter().flat_map(|m| {
                let v = m.col(col);
                [v.x, v.y, v.z, 0.0]
            }));
        }
        stream
            .memcpy_htod(&positions, &mut self.x)
            .context("uploading positions")?;
        stream
            .memcpy_htod(&velocities, &mut self.v)
            .context("uploading velocities")?;
        stream.memcpy_htod(&c, &mut self.c).context("uploading C")?;
        stream
            .memcpy_htod(&particles.rho, &mut self.rho)
            .context("uploading densities")?;
        stream
            .memcpy_htod(&slots_in_place(n), &mut self.slot)
            .context("uploading the particle slots")?;
        match (&mut self.deformation, particles.deformation.is_empty()) {
            (Some(buffer), false) => {
                let mut columns = Vec::with_capacity(12 * n);
                for col in 0..3 {
                    columns.extend(particles.deformation.iter().flat_map(|d| {
                        let v = d.f.col(col);
                        [v.x, v.y, v.z, if col == 0 { d.plastic } else { 0.0 }]
                    }));
                }
                stream
                    .memcpy_htod(&columns, buffer)
                    .context("uploading the deformation gradients")?;
            }
            (None, true) => {}
            (Some(_), true) => {
                bail!("the particles carry no deformation, but a material of the scene carries one")
            }
            (None, false) => {
                bail!("the particles carry a deformation, but no material of the scene carries one")
            }
        }
        stream.synchronize().context("uploading particles")?;
        Ok(())
    }

    /// Stores `slots` as the slot of each place, from the first: a rank's particles are some of the
    /// run's, each known by its slot in the run (`CudaRanks`).
    pub fn upload_slots(&mut self, stream: &Arc<CudaStream>, slots: &[u32]) -> Result<()> {
        ensure!(
            slots.len() <= self.count,
            "{} slots for {} places",
            slots.len(),
            self.count
        );
        stream
            .memcpy_htod(slots, &mut self.slot.slice_mut(..slots.len()))
            .context("uploading the particle slots")
    }

    /// The device ranges, as (address, 32-bit words), that hold `places` of each array: a run of
    /// particles as a transport sends or receives it (`CudaRanks`), listed in one order, so that runs
    /// of one length in two sets list ranges of equal lengths.
    pub fn segments(&self, stream: &CudaStream, places: Range<usize>) -> Result<Vec<(u64, usize)>> {
        ensure!(
            places.start <= places.end && places.end <= self.count,
            "places {places:?} of {} particles",
            self.count
        );
        let (count, len) = (self.count, places.len());
        let word = std::mem::size_of::<f32>() as u64;
        let mut out = Vec::new();
        let mut add = |base: u64, lanes: usize, columns: usize| {
            for col in 0..columns {
                let first = col * lanes * count + lanes * places.start;
                out.push((base + first as u64 * word, lanes * len));
            }
        };
        add(self.x.device_ptr(stream).0, 4, 1);
        add(self.v.device_ptr(stream).0, 4, 1);
        add(self.c.device_ptr(stream).0, 4, 3);
        add(self.rho.device_ptr(stream).0, 1, 1);
        add(self.slot.device_ptr(stream).0, 1, 1);
        if let Some(deformation) = &self.deformation {
            add(deformation.device_ptr(stream).0, 4, 3);
        }
        Ok(out)
    }

    /// These particles in buffers of `capacity` places: each array copied to its start (C's and the
    /// deformation's columns each to its own), the places past `count` parked, holding no slot.
    pub fn grown(&self, stream: &Arc<CudaStream>, capacity: usize) -> Result<DeviceParticles> {
        let n = self.count;
        ensure!(
            capacity >= n,
            "growing {n} particles' buffers to {capacity} places"
        );
        let mut grown = DeviceParticles::allocate(stream, capacity, self.deformation.is_some())?;
        let copy = |from: &CudaSlice<f32>, to: &mut CudaSlice<f32>, lanes: usize, columns: usize| {
            (0..columns).try_for_each(|col| {
                let (src, dst) = (col * lanes * n, col * lanes * capacity);
                stream
                    .memcpy_dtod(
                        &from.slice(src..src + lanes * n),
                        &mut to.slice_mut(dst..dst + lanes * n),
                    )
                    .context("copying particles into larger buffers")
            })
        };
        copy(&self.x, &mut grown.x, 4, 1)?;
        copy(&self.v, &mut grown.v, 4, 1)?;
        copy(&self.c, &mut grown.c, 4, 3)?;
        copy(&self.rho, &mut grown.rho, 1, 1)?;
        if let (Some(from), Some(to)) = (&self.deformation, &mut grown.deformation) {
            copy(from, to, 4, 3)?;
        }
        stream
            .memcpy_dtod(&self.slot, &mut grown.slot.slice_mut(..n))
            .context("copying particle slots into larger buffers")?;
        let parked: Vec<f32> = (n..capacity).flat_map(|_| [0.0, 0.0, 0.0, PARKED_W]).collect();
        stream
            .memcpy_htod(&parked, &mut grown.x.slice_mut(4 * n..))
            .context("parking the new places")?;
        stream
            .memcpy_htod(&vec![NO_SLOT; capacity - n], &mut grown.slot.slice_mut(n..))
            .context("marking the new places slotless")?;
        Ok(grown)
    }

    /// Writes the particles live among the first `places` over their slots of `all` (a run's slots,
    /// on the host, marked live as they are written), waiting for the device: how a host reader
    /// takes a rank's particles without gathering every slot on one GPU (`CudaRanks`). Read
    /// [`READ_PIECE`] places at a time, so the host stages at most a piece. Returns how many it
    /// wrote; a slot out of `all`'s range or written twice is an error.
    pub fn place_live_into(&self, gpu: &Gpu, places: usize, all: &mut Particles) -> Result<usize> {
        ensure!(places <= self.count, "reading {places} places of {}", self.count);
        let mut written = 0;
        for start in (0..places).step_by(READ_PIECE) {
            written += self.place_piece_into(gpu, start..places.min(start + READ_PIECE), all)?;
        }
        Ok(written)
    }

    /// [`Self::place_live_into`] for the places `piece`.
    fn place_piece_into(&self, gpu: &Gpu, piece: Range<usize>, all: &mut Particles) -> Result<usize> {
        let (stream, n) = (gpu.stream(), piece.len());
        // Each of an array's `columns` (C's and the deformation's three) for the piece, one after
        // another.
        let read = |buffer: &CudaSlice<f32>, lanes: usize, columns: usize| -> Result<Vec<f32>> {
            let mut host = vec![0.0f32; lanes * n * columns];
            for (col, out) in host.chunks_mut(lanes * n).enumerate() {
                let first = lanes * (col * self.count + piece.start);
                stream
                    .memcpy_dtoh(&buffer.slice(first..first + lanes * n), out)
                    .context("copying a rank's particles from the GPU")?;
            }
            Ok(host)
        };
        let (x, v, c, rho) = (
            read(&self.x, 4, 1)?,
            read(&self.v, 4, 1)?,
            read(&self.c, 4, 3)?,
            read(&self.rho, 1, 1)?,
        );
        let deformation = match &self.deformation {
            Some(buffer) => Some(read(buffer, 4, 3)?),
            None => None,
        };
        let mut slot = vec![0u32; n];
        stream
            .memcpy_dtoh(&self.slot.slice(piece.clone()), &mut slot)
            .context("copying a rank's particle slots from the GPU")?;
        stream
            .synchronize()
            .context("waiting for the GPU (a kernel may have failed; MPM_CUDA_SYNC=1 names it)")?;
        let host = HostParticles {
            x: &x,
            v: &v,
            c: Some(&c),
            rho: &rho,
            slot: &slot,
            deformation: deformation.as_deref(),
        };
        host.place_live_into(all, piece.start)
    }

    /// A host copy of every slot, in slot order, waiting for the device.
    pub fn download(&self, gpu: &Gpu) -> Result<Particles> {
        let deformation = match &self.deformation {
            Some(buffer) => Some(gpu.download(buffer)?),
            None => None,
        };
        let host = HostParticles {
            x: &gpu.download(&self.x)?,
            v: &gpu.download(&self.v)?,
            c: Some(&gpu.download(&self.c)?),
            rho: &gpu.download(&self.rho)?,
            slot: &gpu.download(&self.slot)?,
            deformation: deformation.as_deref(),
        };
        host.in_slot_order()
    }
}

/// The device's particle buffers as copied to the host, in memory order: `download`'s, and the
/// export snapshots' (snapshot.rs), which leave C behind.
pub struct HostParticles<'a> {
    pub x: &'a [f32],
    pub v: &'a [f32],
    /// None: the particles come back without C (`Particles::c` empty).
    pub c: Option<&'a [f32]>,
    pub rho: &'a [f32],
    pub slot: &'a [u32],
    pub deformation: Option<&'a [f32]>,
}

impl HostParticles<'_> {
    /// The particles in slot order, each unpacked from its float4s. On the calling thread, not on
    /// rayon's pool: the export thread does this for every exported frame, while the surface and
    /// volume workers may hold the pool for seconds.
    pub fn in_slot_order(&self) -> Result<Particles> {
        let place = places_of_slots(self.slot)?;
        Ok(Particles {
            x: place.iter().map(|&i| self.x_at(i)).collect(),
            v: place.iter().map(|&i| self.v_at(i)).collect(),
            c: match self.c {
                Some(c) => place.iter().map(|&i| self.columns(c, i)).collect(),
                None => Vec::new(),
            },
            rho: place.iter().map(|&i| self.rho[i]).collect(),
            material: place.iter().map(|&i| self.material_at(i)).collect(),
            live: place.iter().map(|&i| self.live_at(i)).collect(),
            deformation: match self.deformation {
                Some(d) => place.iter().map(|&i| self.deformation_at(d, i)).collect(),
                None => Vec::new(),
            },
            // The position-based solver's alone, which runs on the CPU.
            volume_bias: Vec::new(),
        })
    }

    /// Writes the live places over their slots of `all` (a run's slots; these places some of a
    /// rank's, the first of them its place `first`), marking them live: a piece of
    /// `DeviceParticles::place_live_into`. Returns how many it wrote; a slot out of `all`'s range
    /// or written twice is an error.
    pub fn place_live_into(&self, all: &mut Particles, first: usize) -> Result<usize> {
        let c = self.c.context("a rank's particles read without C")?;
        ensure!(
            self.deformation.is_none() || all.deformation.len() == all.len(),
            "a rank's particles carry a deformation the run's set has no room for"
        );
        let mut written = 0;
        for i in (0..self.slot.len()).filter(|&i| self.live_at(i)) {
            let s = self.slot[i] as usize;
            ensure!(
                s < all.len() && !all.live[s],
                "slot {s} (place {} of a rank) is out of the run's {} slots or live on two ranks",
                first + i,
                all.len()
            );
            (all.x[s], all.v[s], all.c[s]) = (self.x_at(i), self.v_at(i), self.columns(c, i));
            (all.rho[s], all.live[s], all.material[s]) = (self.rho[i], true, self.material_at(i));
            if let Some(d) = self.deformation {
                all.deformation[s] = self.deformation_at(d, i);
            }
            written += 1;
        }
        Ok(written)
    }

    fn x_at(&self, i: usize) -> Vec3 {
        lanes_xyz(self.x, i)
    }

    fn v_at(&self, i: usize) -> Vec3 {
        lanes_xyz(self.v, i)
    }

    /// x.w: 0 for a live particle, PARKED_W for a parked slot.
    fn live_at(&self, i: usize) -> bool {
        self.x[4 * i + 3] == 0.0
    }

    fn material_at(&self, i: usize) -> u8 {
        material_of_tag(self.v[4 * i + 3])
    }

    /// Place `i`'s matrix of an array of three float4 columns (C, or F_E), each column as many
    /// places long as these.
    fn columns(&self, a: &[f32], i: usize) -> Mat3 {
        let n = self.slot.len();
        Mat3::from_cols(lanes_xyz(a, i), lanes_xyz(a, n + i), lanes_xyz(a, 2 * n + i))
    }

    /// F_E's columns, the plastic scalar in the first one's w.
    fn deformation_at(&self, d: &[f32], i: usize) -> Deformation {
        Deformation {
            f: self.columns(d, i),
            plastic: d[4 * i + 3],
        }
    }
}

/// The x, y, z lanes of float4 `i` of `a`.
fn lanes_xyz(a: &[f32], i: usize) -> Vec3 {
    Vec3::new(a[4 * i], a[4 * i + 1], a[4 * i + 2])
}

/// v.w of a particle of material row `material`: the row's bits (kernels/material.cuh
/// `material_row`); 0.0 for row 0, as a scene of one material has it.
pub fn material_tag(material: u8) -> f32 {
    f32::from_bits(u32::from(material))
}

/// The material row a v.w holds ([`material_tag`]).
pub fn material_of_tag(tag: f32) -> u8 {
    tag.to_bits().min(u32::from(u8::MAX)) as u8
}

/// Each particle stored at its own slot: the slot of each place, or the place of each slot.
pub fn slots_in_place(count: usize) -> Vec<u32> {
    (0..count as u32).collect()
}

/// Per slot, the place in memory that holds it, from the slot stored at each place: checked to be
/// a permutation, so that a corrupted buffer is an error rather than particles lost or doubled.
pub fn places_of_slots(slot: &[u32]) -> Result<Vec<usize>> {
    let mut place = vec![usize::MAX; slot.len()];
    for (i, &s) in slot.iter().enumerate() {
        let entry = place.get_mut(s as usize);
        ensure!(
            entry.as_ref().is_some_and(|p| **p == usize::MAX),
            "the device's particle slots are not a permutation (slot {s} at place {i} of {}): \
             a kernel wrote past its particles",
            slot.len()
        );
        if let Some(p) = entry {
            *p = i;
        }
    }
    Ok(place)
}

#[cfg(test)]
mod tests {
    use super::{places_of_slots, HostParticles};
    use crate::contract::PARKED_W;
    use crate::sim::Particles;

    /// A rank's places written over their slots give each live particle exactly as the whole set
    /// unpacked in slot order has it, the parked place left out.
    #[test]
    fn live_places_land_on_their_slots_as_the_slot_order_unpacks_them() {
        // Four places in memory order holding slots 2, 0, 3, 1, the third parked, every value
        // distinct.
        let float4s = |base: f32, w: [f32; 4]| -> Vec<f32> {
            (0..16)
                .map(|k| if k % 4 == 3 { w[k / 4] } else { base + k as f32 })
                .collect()
        };
        let x = float4s(0.0, [0.0, 0.0, PARKED_W, 0.0]);
        let v = float4s(100.0, [0.0, f32::from_bits(1), 0.0, f32::from_bits(2)]);
        let c: Vec<f32> = (0..48).map(|k| 200.0 + k as f32).collect();
        let d: Vec<f32> = (0..48).map(|k| 300.0 + k as f32).collect();
        let (rho, slot) = (vec![1.0, 2.0, 3.0, 4.0], vec![2, 0, 3, 1]);
        let host = HostParticles {
            x: &x,
            v: &v,
            c: Some(&c),
            rho: &rho,
            slot: &slot,
            deformation: Some(&d),
        };
        let whole = host.in_slot_order().unwrap();
        // Slot 0 lies at place 1: its float4s' lanes 4 to 6, C's and F_E's columns a column (4
        // places of 4 lanes) apart, the plastic scalar in F_E's first column's w, material row 1.
        let vec3 = |a: f32| glam::Vec3::new(a, a + 1.0, a + 2.0);
        assert_eq!(
            (whole.x[0], whole.v[0], whole.rho[0]),
            (vec3(4.0), vec3(104.0), 2.0)
        );
        assert_eq!(
            whole.c[0],
            glam::Mat3::from_cols(vec3(204.0), vec3(220.0), vec3(236.0))
        );
        let f = glam::Mat3::from_cols(vec3(304.0), vec3(320.0), vec3(336.0));
        assert_eq!((whole.deformation[0].f, whole.deformation[0].plastic), (f, 307.0));
        assert_eq!(
            (whole.material[0], whole.live),
            (1, vec![true, true, true, false])
        );
        let mut all = Particles::default();
        all.park_more(4);
        all.c = vec![glam::Mat3::ZERO; 4];
        all.deformation = vec![crate::sim::Deformation::at_rest(0); 4];
        assert_eq!(host.place_live_into(&mut all, 0).unwrap(), 3);
        assert_eq!(
            all.live,
            vec![true, true, true, false],
            "slot 3's place is parked"
        );
        for s in 0..3 {
            assert_eq!(
                (
                    all.x[s],
                    all.v[s],
                    all.c[s],
                    all.rho[s],
                    all.material[s],
                    all.deformation[s]
                ),
                (
                    whole.x[s],
                    whole.v[s],
                    whole.c[s],
                    whole.rho[s],
                    whole.material[s],
                    whole.deformation[s]
                ),
                "slot {s}"
            );
        }
        let twice = host.place_live_into(&mut all, 0).unwrap_err().to_string();
        assert!(twice.contains("live on two ranks"), "{twice}");
    }

    #[test]
    fn places_invert_the_stored_slots() {
        assert_eq!(places_of_slots(&[2, 0, 1]).unwrap(), vec![1, 2, 0]);
        assert_eq!(places_of_slots(&[0, 1, 2, 3]).unwrap(), vec![0, 1, 2, 3]);
    }

    #[test]
    fn a_slot_twice_or_out_of_range_is_an_error() {
        let twice = places_of_slots(&[0, 0, 1]).unwrap_err().to_string();
        assert!(twice.contains("slot 0 at place 1"), "{twice}");
        assert!(places_of_slots(&[0, 3, 1]).is_err());
    }
}
