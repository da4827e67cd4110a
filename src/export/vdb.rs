//! OpenVDB files (`.vdb`), written by the project: no maintained Rust crate writes them (`vdb-rs`
//! reads only). What is written is the subset a volume export needs:
//!
//! - file format version 224 (`OPENVDB_FILE_VERSION_MULTIPASS_IO`), the version OpenVDB 6 to 10
//!   write and every later one reads (so Blender and Houdini, which bundle those libraries);
//! - grids of floats (`Tree_float_5_4_3`) and of 3-vectors of floats (`Tree_vec3s_5_4_3`), each a
//!   standard tree: a root table of 4096^3-voxel internal nodes (32^3 slots), 128^3-voxel internal
//!   nodes (16^3 slots) and 8^3-voxel leaves;
//! - values as 32-bit floats, or as 16-bit halves (the type name's `_HalfFloat` suffix and the
//!   `is_saved_as_half_float` metadata: the leaves' and internal nodes' values as halves, the
//!   root's background, tiles and each node's inactive values as floats rounded to half precision);
//! - the active-mask compression (`COMPRESS_ACTIVE_MASK`: a node stores its active values, and its
//!   inactive ones as at most two values and a mask choosing between them), no zip and no blosc;
//! - a uniform scale transform (`UniformScaleMap`): voxel `(i, j, k)` sits at world `h (i, j, k)`;
//! - grid metadata: `name`, `class` (`level set`, `fog volume`), `vector_type`,
//!   `is_saved_as_half_float`, `is_local_space`, `file_compression`, `file_bbox_min`/`_max`,
//!   `file_voxel_count`; and metadata of the file.
//!
//! Written from the format as OpenVDB's own I/O code defines it, read (never copied) from the
//! AcademySoftwareFoundation/openvdb repository (Apache-2.0), openvdb/openvdb/:
//! `io/Archive.cc` (`Archive::writeHeader`, `Archive::write`, `Archive::writeGrid`,
//! `setGridCompression`: the header, the grid count, each grid's descriptor, compression flags,
//! metadata, transform, topology and buffers, and the three stream offsets),
//! `io/GridDescriptor.cc` (`writeHeader`, `writeStreamPos`: name, type, instance parent, offsets),
//! `io/Compression.h` (`writeCompressedValues`, `readCompressedValues`, the per-node metadata byte
//! and what each of its values means to a reader), `MetaMap.cc` and `Metadata.h` (a metadata
//! record: name, type name, size, bytes), `util/Name.h` (`writeString`), `math/Transform.cc` and
//! `math/Maps.h` (`Transform::write`, `ScaleMap::write`), `tree/Tree.h` (`writeTopology`: the
//! buffer count), `tree/RootNode.h`, `tree/InternalNode.h` and `tree/LeafNode.h` (`writeTopology`,
//! `writeBuffers`, the order of children and of voxels in a node), `Grid.cc` (the metadata names
//! and the strings of grid classes and vector types) and `version.h.in` (the magic number and the
//! file versions). The reader of the Traverse-Research/vdb-rs crate (`src/reader.rs`, MIT) showed
//! which of the reader's paths a second implementation follows: it restores inactive values only
//! from the values a node stores, so every node here stores its inactive values explicitly
//! (metadata 2, 5 or 6, never the 0, 1, 3 and 4 that let OpenVDB's reader assume the background),
//! which OpenVDB's reader reads the same. tests/volume_export.rs reads the files back with vdb-rs,
//! tests/volume_readers.rs with OpenVDB's own library (its Python bindings).

use std::collections::{BTreeMap, HashMap, HashSet};
use std::hash::{BuildHasher, Hasher};
use std::io::{self, Write};

/// The file format version written (OpenVDB's `OPENVDB_FILE_VERSION_MULTIPASS_IO`).
pub const FILE_VERSION: u32 = 224;
/// The library version the header names: the last OpenVDB whose writer writes version 224 (10.x).
/// Readers only report it.
const LIBRARY_VERSION: (u32, u32) = (10, 0);
/// `OPENVDB_MAGIC`, "VDB " as a little-endian 64-bit integer.
const MAGIC: i64 = 0x5644_4220;
/// `io::COMPRESS_ACTIVE_MASK`: a node writes its active values and, separately, its inactive ones.
const COMPRESS_ACTIVE_MASK: u32 = 0x2;
/// Per-node metadata (io/Compression.h): all inactive values equal the one value stored.
const NO_MASK_AND_ONE_INACTIVE_VAL: u8 = 2;
/// Two inactive values stored, and a mask choosing the second where its bit is on.
const MASK_AND_TWO_INACTIVE_VALS: u8 = 5;
/// Every value stored (more than two distinct inactive values).
const NO_MASK_AND_ALL_VALS: u8 = 6;

/// A voxel's index coordinates.
pub type Coord = [i32; 3];

/// log2 of a leaf's edge in voxels (8).
pub const LEAF_LOG2: u32 = 3;
/// Voxels in a leaf (8^3).
pub const LEAF_SIZE: usize = 1 << (3 * LEAF_LOG2);
/// log2 of the edge, in voxels, of the internal nodes under the root (4096) and under them (128).
const NODE5_TOTAL: u32 = 12;
const NODE4_TOTAL: u32 = 7;

/// The origin of the node of edge `2^log2` voxels that holds `ijk` (two's complement: a floor).
pub fn node_origin(ijk: Coord, log2: u32) -> Coord {
    ijk.map(|c| c & !((1i32 << log2) - 1))
}

/// The voxel's place in its leaf's buffer: x slowest, z fastest (LeafNode::coordToOffset).
pub fn leaf_offset(ijk: Coord) -> usize {
    let m = (1 << LEAF_LOG2) - 1;
    (((ijk[0] & m) as usize) << (2 * LEAF_LOG2))
        | (((ijk[1] & m) as usize) << LEAF_LOG2)
        | (ijk[2] & m) as usize
}

/// The coordinates of place `offset` of the leaf at `origin`.
pub fn leaf_coord(origin: Coord, offset: usize) -> Coord {
    let m = (1 << LEAF_LOG2) - 1;
    [
        origin[0] + (offset >> (2 * LEAF_LOG2)) as i32,
        origin[1] + ((offset >> LEAF_LOG2) & m) as i32,
        origin[2] + (offset & m) as i32,
    ]
}

/// The slot of child `child` (an origin) in the internal node of edge `2^total` voxels whose
/// children have edge `2^child_total` (InternalNode::coordToOffset): x slowest.
fn slot(child: Coord, total: u32, child_total: u32) -> usize {
    let log2 = total - child_total;
    let m = (1i32 << total) - 1;
    let s = |c: i32| ((c & m) >> child_total) as usize;
    (s(child[0]) << (2 * log2)) | (s(child[1]) << log2) | s(child[2])
}

/// The origin of slot `slot` of the internal node at `origin`.
fn slot_origin(origin: Coord, slot: usize, total: u32, child_total: u32) -> Coord {
    let log2 = total - child_total;
    let m = (1usize << log2) - 1;
    [
        origin[0] + (((slot >> (2 * log2)) & m) << child_total) as i32,
        origin[1] + (((slot >> log2) & m) << child_total) as i32,
        origin[2] + ((slot & m) << child_total) as i32,
    ]
}

/// A type of voxel value a grid holds.
pub trait Value: Copy + PartialEq + Default + Send + Sync + std::fmt::Debug + 'static {
    /// The value type's name in the tree's type name, `Tree_<name>_5_4_3`.
    const NAME: &'static str;
    /// Appends the value as little-endian 32-bit floats.
    fn put(self, out: &mut Vec<u8>);
    /// Appends the value as little-endian 16-bit halves.
    fn put_half(self, out: &mut Vec<u8>);
    /// The value rounded to half precision and back (OpenVDB's `truncateRealToHalf`): what a half
    /// grid holds.
    fn to_half_precision(self) -> Self;
}

fn half_bits(x: f32) -> [u8; 2] {
    half::f16::from_f32(x).to_bits().to_le_bytes()
}

impl Value for f32 {
    const NAME: &'static str = "float";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
    fn put_half(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&half_bits(self));
    }
    fn to_half_precision(self) -> f32 {
        half::f16::from_f32(self).to_f32()
    }
}

impl Value for [f32; 3] {
    const NAME: &'static str = "vec3s";
    fn put(self, out: &mut Vec<u8>) {
        for c in self {
            c.put(out);
        }
    }
    fn put_half(self, out: &mut Vec<u8>) {
        for c in self {
            c.put_half(out);
        }
    }
    fn to_half_precision(self) -> [f32; 3] {
        self.map(f32::to_half_precision)
    }
}

/// An 8^3 block of voxels: a value each, and which of them are active.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf<T> {
    pub values: Box<[T; LEAF_SIZE]>,
    /// Bit `n` of word `n / 64` is on where voxel `n` is active.
    pub active: [u64; LEAF_SIZE / 64],
}

impl<T: Value> Leaf<T> {
    /// Every voxel `fill`, none active.
    pub fn filled(fill: T) -> Leaf<T> {
        Leaf {
            values: Box::new([fill; LEAF_SIZE]),
            active: [0; LEAF_SIZE / 64],
        }
    }

    pub fn set(&mut self, offset: usize, value: T, active: bool) {
        self.values[offset] = value;
        let (word, bit) = (offset / 64, offset % 64);
        if active {
            self.active[word] |= 1 << bit;
        } else {
            self.active[word] &= !(1 << bit);
        }
    }

    pub fn is_active(&self, offset: usize) -> bool {
        self.active[offset / 64] >> (offset % 64) & 1 == 1
    }

    pub fn active_count(&self) -> u64 {
        self.active.iter().map(|w| u64::from(w.count_ones())).sum()
    }
}

/// A sparse grid's voxels: leaves by origin, the inactive tiles whose value is not the background
/// (a level set's inside), and the background everywhere else.
#[derive(Clone, Debug)]
pub struct Tree<T> {
    pub background: T,
    leaves: BTreeMap<Coord, Leaf<T>>,
    /// Tiles by (origin, log2 of their edge: 3 for an 8^3 slot of a 128^3 node, 7 for a 128^3 slot
    /// of a 4096^3 node, 12 for a 4096^3 slot of the root); all inactive. A tile counts only where
    /// the node above it exists (holds a leaf), as in the file.
    tiles: HashMap<(Coord, u32), T>,
    /// The origins of the 128^3 and 4096^3 nodes: those that hold a leaf.
    node4s: HashSet<Coord>,
    node5s: HashSet<Coord>,
}

impl<T: Value> Tree<T> {
    pub fn new(background: T) -> Tree<T> {
        Tree {
            background,
            leaves: BTreeMap::new(),
            tiles: HashMap::new(),
            node4s: HashSet::new(),
            node5s: HashSet::new(),
        }
    }

    /// Adds (or replaces) the leaf at `origin`, a multiple of 8 on every axis.
    pub fn insert_leaf(&mut self, origin: Coord, leaf: Leaf<T>) {
        debug_assert_eq!(origin, node_origin(origin, LEAF_LOG2));
        self.node4s.insert(node_origin(origin, NODE4_TOTAL));
        self.node5s.insert(node_origin(origin, NODE5_TOTAL));
        self.leaves.insert(origin, leaf);
    }

    /// Gives the region of edge `2^log2` voxels at `origin` (log2 3, 7 or 12) the inactive value
    /// `value` where no leaf lies in it.
    pub fn set_tile(&mut self, origin: Coord, log2: u32, value: T) {
        debug_assert!(matches!(log2, 3 | 7 | 12));
        debug_assert_eq!(origin, node_origin(origin, log2));
        if value == self.background {
            self.tiles.remove(&(origin, log2));
        } else {
            self.tiles.insert((origin, log2), value);
        }
    }

    pub fn leaves(&self) -> impl Iterator<Item = (&Coord, &Leaf<T>)> {
        self.leaves.iter()
    }

    pub fn leaf(&self, origin: Coord) -> Option<&Leaf<T>> {
        self.leaves.get(&origin)
    }

    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    /// The voxel's value and whether it is active, as a reader of the file finds it.
    pub fn value(&self, ijk: Coord) -> (T, bool) {
        if let Some(leaf) = self.leaves.get(&node_origin(ijk, LEAF_LOG2)) {
            let n = leaf_offset(ijk);
            return (leaf.values[n], leaf.is_active(n));
        }
        // The slot of the deepest node that exists holds the value.
        let log2 = if self.node4s.contains(&node_origin(ijk, NODE4_TOTAL)) {
            LEAF_LOG2
        } else if self.node5s.contains(&node_origin(ijk, NODE5_TOTAL)) {
            NODE4_TOTAL
        } else {
            NODE5_TOTAL
        };
        let tile = self.tiles.get(&(node_origin(ijk, log2), log2));
        (*tile.unwrap_or(&self.background), false)
    }

    pub fn active_voxel_count(&self) -> u64 {
        self.leaves.values().map(Leaf::active_count).sum()
    }

    /// The smallest box holding every active voxel, inclusive; `None` where none is.
    pub fn active_bbox(&self) -> Option<(Coord, Coord)> {
        let mut bbox: Option<(Coord, Coord)> = None;
        for (&origin, leaf) in &self.leaves {
            for n in (0..LEAF_SIZE).filter(|&n| leaf.is_active(n)) {
                let c = leaf_coord(origin, n);
                let (lo, hi) = bbox.get_or_insert((c, c));
                for a in 0..3 {
                    lo[a] = lo[a].min(c[a]);
                    hi[a] = hi[a].max(c[a]);
                }
            }
        }
        bbox
    }
}

/// What a grid holds, in OpenVDB's words (the `class` metadata).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GridClass {
    /// Signed distance, negative inside, its background the band's half width in world units.
    LevelSet,
    /// Density, 0 outside.
    FogVolume,
    Unknown,
}

impl GridClass {
    /// `GridBase::gridClassToString`.
    pub fn name(self) -> &'static str {
        match self {
            GridClass::LevelSet => "level set",
            GridClass::FogVolume => "fog volume",
            GridClass::Unknown => "unknown",
        }
    }
}

/// One grid of a file.
#[derive(Clone, Debug)]
pub struct Grid<T> {
    pub name: String,
    pub class: GridClass,
    /// The `vector_type` metadata of a vector grid (`contravariant relative` for a velocity).
    pub vector_type: Option<&'static str>,
    /// The voxel's edge in world units.
    pub voxel_size: f64,
    /// Values as 16-bit halves.
    pub half: bool,
    pub tree: Tree<T>,
}

/// A metadata value, of the types written here.
#[derive(Debug, Clone, PartialEq)]
pub enum Meta {
    String(String),
    Bool(bool),
    Int64(i64),
    Float(f32),
    Vec3i([i32; 3]),
}

impl Meta {
    fn type_name(&self) -> &'static str {
        match self {
            Meta::String(_) => "string",
            Meta::Bool(_) => "bool",
            Meta::Int64(_) => "int64",
            Meta::Float(_) => "float",
            Meta::Vec3i(_) => "vec3i",
        }
    }
}

/// Appends what `writeString` writes: the length as a 32-bit integer, then the bytes.
fn put_string(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

/// Appends a metadata map (MetaMap::writeMeta): the count, then name, type name, size and bytes of
/// each record.
fn put_metadata(out: &mut Vec<u8>, records: &[(&str, Meta)]) {
    out.extend_from_slice(&(records.len() as u32).to_le_bytes());
    for (name, value) in records {
        put_string(out, name);
        put_string(out, value.type_name());
        let mut bytes = Vec::new();
        match value {
            Meta::String(s) => bytes.extend_from_slice(s.as_bytes()),
            Meta::Bool(b) => bytes.push(u8::from(*b)),
            Meta::Int64(i) => bytes.extend_from_slice(&i.to_le_bytes()),
            Meta::Float(f) => bytes.extend_from_slice(&f.to_le_bytes()),
            Meta::Vec3i(v) => v.iter().for_each(|c| bytes.extend_from_slice(&c.to_le_bytes())),
        }
        out.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(&bytes);
    }
}

fn put_words(out: &mut Vec<u8>, words: &[u64]) {
    for w in words {
        out.extend_from_slice(&w.to_le_bytes());
    }
}

fn bit(mask: &[u64], n: usize) -> bool {
    mask[n / 64] >> (n % 64) & 1 == 1
}

/// Appends a node's values as `writeCompressedValues` does under the active-mask compression: the
/// metadata byte, the inactive values, the selection mask, then the values (the active ones alone,
/// unless more than two inactive values differ). Slots holding a child (`children`) are neither.
/// Inactive values are told apart as the file holds them (after rounding to half precision).
fn put_values<T: Value>(
    out: &mut Vec<u8>,
    values: &[T],
    active: &[u64],
    children: Option<&[u64]>,
    half: bool,
) {
    let stored = |v: T| if half { v.to_half_precision() } else { v };
    let child = |n: usize| children.is_some_and(|c| bit(c, n));
    let mut distinct: Vec<T> = Vec::with_capacity(3);
    for n in (0..values.len()).filter(|&n| !bit(active, n) && !child(n)) {
        let v = stored(values[n]);
        if !distinct.contains(&v) {
            distinct.push(v);
            if distinct.len() > 2 {
                break;
            }
        }
    }
    let put = |out: &mut Vec<u8>, v: T| if half { v.put_half(out) } else { v.put(out) };
    match distinct.len() {
        0 | 1 => {
            out.push(NO_MASK_AND_ONE_INACTIVE_VAL);
            // The inactive value at full width (as OpenVDB writes it, a half grid's rounded).
            distinct.first().copied().unwrap_or_default().put(out);
        }
        2 => {
            out.push(MASK_AND_TWO_INACTIVE_VALS);
            distinct[0].put(out);
            distinct[1].put(out);
            let mut selection = vec![0u64; values.len().div_ceil(64)];
            for n in (0..values.len()).filter(|&n| !bit(active, n) && !child(n)) {
                if stored(values[n]) == distinct[1] {
                    selection[n / 64] |= 1 << (n % 64);
                }
            }
            put_words(out, &selection);
        }
        _ => {
            out.push(NO_MASK_AND_ALL_VALS);
            for &v in values {
                put(out, v);
            }
            return;
        }
    }
    for n in (0..values.len()).filter(|&n| bit(active, n)) {
        put(out, values[n]);
    }
}

/// The tree's nodes: the 4096^3 nodes by origin, each with its 128^3 nodes by slot, each with its
/// leaves by slot, every level in the order a reader expects (root table by coordinates, x first;
/// children by slot).
type Nodes = BTreeMap<Coord, BTreeMap<usize, BTreeMap<usize, Coord>>>;

fn nodes<T>(tree: &Tree<T>) -> Nodes {
    let mut nodes = Nodes::new();
    for &origin in tree.leaves.keys() {
        let n4 = node_origin(origin, NODE4_TOTAL);
        nodes
            .entry(node_origin(origin, NODE5_TOTAL))
            .or_default()
            .entry(slot(n4, NODE5_TOTAL, NODE4_TOTAL))
            .or_default()
            .insert(slot(origin, NODE4_TOTAL, LEAF_LOG2), origin);
    }
    nodes
}

impl<T: Value> Grid<T> {
    /// The tree's type name as the grid descriptor writes it.
    pub fn type_name(&self) -> String {
        format!(
            "Tree_{}_5_4_3{}",
            T::NAME,
            if self.half { "_HalfFloat" } else { "" }
        )
    }

    fn metadata(&self) -> Vec<(&'static str, Meta)> {
        // Sorted by name, as OpenVDB's map of metadata writes them.
        let mut records = vec![("class", Meta::String(self.class.name().into()))];
        if let Some((lo, hi)) = self.tree.active_bbox() {
            records.push(("file_bbox_max", Meta::Vec3i(hi)));
            records.push(("file_bbox_min", Meta::Vec3i(lo)));
        }
        records.push(("file_compression", Meta::String("active values".into())));
        records.push((
            "file_voxel_count",
            Meta::Int64(self.tree.active_voxel_count() as i64),
        ));
        records.push(("is_local_space", Meta::Bool(false)));
        records.push(("is_saved_as_half_float", Meta::Bool(self.half)));
        records.push(("name", Meta::String(self.name.clone())));
        if let Some(vector_type) = self.vector_type {
            records.push(("vector_type", Meta::String(vector_type.into())));
        }
        records
    }

    /// The grid as a file stores it at its grid offset (compression flags, metadata, transform,
    /// topology) and at its block offset (the leaves' buffers).
    fn serialize(&self) -> (Vec<u8>, Vec<u8>) {
        let stored = |v: T| if self.half { v.to_half_precision() } else { v };
        let tree = &self.tree;
        let mut head = Vec::new();
        head.extend_from_slice(&COMPRESS_ACTIVE_MASK.to_le_bytes());
        put_metadata(&mut head, &self.metadata());
        put_string(&mut head, "UniformScaleMap");
        let h = self.voxel_size;
        // ScaleMap::write: scale, voxel size, 1 / scale, 1 / scale^2, 1 / (2 scale).
        for v in [h, h, 1.0 / h, 1.0 / (h * h), 0.5 / h] {
            for _ in 0..3 {
                head.extend_from_slice(&v.to_le_bytes());
            }
        }
        // Tree::writeTopology: one buffer; then the root.
        head.extend_from_slice(&1i32.to_le_bytes());
        stored(tree.background).put(&mut head);
        let nodes = nodes(tree);
        let mut root_tiles: Vec<(Coord, T)> = tree
            .tiles
            .iter()
            .filter(|((origin, log2), _)| *log2 == NODE5_TOTAL && !nodes.contains_key(origin))
            .map(|(&(origin, _), &v)| (origin, v))
            .collect();
        root_tiles.sort_by_key(|&(origin, _)| origin);
        head.extend_from_slice(&(root_tiles.len() as u32).to_le_bytes());
        head.extend_from_slice(&(nodes.len() as u32).to_le_bytes());
        for (origin, value) in root_tiles {
            origin
                .iter()
                .for_each(|c| head.extend_from_slice(&c.to_le_bytes()));
            stored(value).put(&mut head);
            head.push(0); // inactive
        }
        let tile = |origin: Coord, log2: u32| *tree.tiles.get(&(origin, log2)).unwrap_or(&tree.background);
        let mut buffers = Vec::new();
        for (&n5, children) in &nodes {
            n5.iter().for_each(|c| head.extend_from_slice(&c.to_le_bytes()));
            self.put_internal(&mut head, n5, NODE5_TOTAL, NODE4_TOTAL, children.keys(), &tile);
            for (&s4, leaves) in children {
                let n4 = slot_origin(n5, s4, NODE5_TOTAL, NODE4_TOTAL);
                self.put_internal(&mut head, n4, NODE4_TOTAL, LEAF_LOG2, leaves.keys(), &tile);
                for origin in leaves.values() {
                    let leaf = &tree.leaves[origin];
                    // LeafNode::writeTopology: the value mask; writeBuffers: the mask and values.
                    put_words(&mut head, &leaf.active);
                    put_words(&mut buffers, &leaf.active);
                    put_values(&mut buffers, &leaf.values[..], &leaf.active, None, self.half);
                }
            }
        }
        (head, buffers)
    }

    /// InternalNode::writeTopology without the children: the child mask, the value mask (no
    /// active tiles here), then the slots' values (a tile's, or zero under a child).
    fn put_internal<'a>(
        &self,
        out: &mut Vec<u8>,
        origin: Coord,
        total: u32,
        child_total: u32,
        children: impl Iterator<Item = &'a usize>,
        tile: &dyn Fn(Coord, u32) -> T,
    ) {
        let slots = 1usize << (3 * (total - child_total));
        let mut child_mask = vec![0u64; slots / 64];
        for &s in children {
            child_mask[s / 64] |= 1 << (s % 64);
        }
        let value_mask = vec![0u64; slots / 64];
        let values: Vec<T> = (0..slots)
            .map(|s| match bit(&child_mask, s) {
                true => T::default(),
                false => tile(slot_origin(origin, s, total, child_total), child_total),
            })
            .collect();
        put_words(out, &child_mask);
        put_words(out, &value_mask);
        put_values(out, &values, &value_mask, Some(&child_mask), self.half);
    }
}

/// A grid of any value type, for a file of several.
pub trait AnyGrid: Sync {
    fn name(&self) -> &str;
    fn type_name(&self) -> String;
    fn serialize(&self) -> (Vec<u8>, Vec<u8>);
}

impl<T: Value> AnyGrid for Grid<T> {
    fn name(&self) -> &str {
        &self.name
    }
    fn type_name(&self) -> String {
        Grid::type_name(self)
    }
    fn serialize(&self) -> (Vec<u8>, Vec<u8>) {
        Grid::serialize(self)
    }
}

/// A random UUID in the 8-4-4-4-12 hexadecimal form the header holds (a file's identity for a
/// reader's cache; std's randomly seeded hasher is random enough for that).
fn uuid() -> String {
    let state = std::collections::hash_map::RandomState::new();
    let mut hex = String::new();
    for i in 0..2u64 {
        let mut h = state.build_hasher();
        h.write_u64(i);
        h.write_u128(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
        );
        hex += &format!("{:016X}", h.finish());
    }
    format!(
        "{}-{}-{}-{}-{}",
        &hex[..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

/// Writes a `.vdb` file of `grids` (names unique) with the file's `metadata`.
pub fn write(out: &mut impl Write, grids: &[&dyn AnyGrid], metadata: &[(&str, Meta)]) -> io::Result<()> {
    let mut head = Vec::new();
    head.extend_from_slice(&MAGIC.to_le_bytes());
    head.extend_from_slice(&FILE_VERSION.to_le_bytes());
    head.extend_from_slice(&LIBRARY_VERSION.0.to_le_bytes());
    head.extend_from_slice(&LIBRARY_VERSION.1.to_le_bytes());
    head.push(1); // the grids' offsets follow their descriptors
    head.extend_from_slice(uuid().as_bytes());
    put_metadata(&mut head, metadata);
    head.extend_from_slice(&(grids.len() as i32).to_le_bytes());
    out.write_all(&head)?;
    let mut at = head.len() as u64;
    for grid in grids {
        let (body, buffers) = grid.serialize();
        let mut descriptor = Vec::new();
        put_string(&mut descriptor, grid.name());
        put_string(&mut descriptor, &grid.type_name());
        put_string(&mut descriptor, ""); // no instance parent
        let grid_pos = at + descriptor.len() as u64 + 24;
        let block_pos = grid_pos + body.len() as u64;
        let end_pos = block_pos + buffers.len() as u64;
        for pos in [grid_pos, block_pos, end_pos] {
            descriptor.extend_from_slice(&(pos as i64).to_le_bytes());
        }
        out.write_all(&descriptor)?;
        out.write_all(&body)?;
        out.write_all(&buffers)?;
        at = end_pos;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_follow_openvdb_order() {
        assert_eq!(leaf_offset([0, 0, 1]), 1);
        assert_eq!(leaf_offset([0, 1, 0]), 8);
        assert_eq!(leaf_offset([1, 0, 0]), 64);
        assert_eq!(leaf_offset([-1, -1, -1]), 511);
        for n in [0, 1, 77, 511] {
            assert_eq!(leaf_offset(leaf_coord([8, -16, 24], n)), n);
        }
        assert_eq!(node_origin([-1, 5, 4096], 12), [-4096, 0, 4096]);
        assert_eq!(slot([128, 0, 0], NODE5_TOTAL, NODE4_TOTAL), 1 << 10);
        assert_eq!(slot([0, 0, 8], NODE4_TOTAL, LEAF_LOG2), 1);
        assert_eq!(
            slot_origin([0, 0, 0], 1 << 10, NODE5_TOTAL, NODE4_TOTAL),
            [128, 0, 0]
        );
        assert_eq!(
            slot_origin([-128, 0, 0], 4095, NODE4_TOTAL, LEAF_LOG2),
            [-8, 120, 120]
        );
    }

    #[test]
    fn inactive_values_are_stored_one_two_or_all() {
        let active = [0u64; 8];
        let mut one = Vec::new();
        put_values(&mut one, &[3.0f32; 512], &active, None, false);
        assert_eq!(one, [&[2u8][..], &3.0f32.to_le_bytes()].concat());

        let mut values = [1.0f32; 512];
        values[5] = -1.0;
        let mut active = [0u64; 8];
        active[0] = 1; // voxel 0 active, value 1
        let mut two = Vec::new();
        put_values(&mut two, &values, &active, None, false);
        assert_eq!(two[0], 5);
        assert_eq!(
            &two[1..9],
            [1.0f32.to_le_bytes(), (-1.0f32).to_le_bytes()].concat()
        );
        let selection: Vec<u64> = (0..8)
            .map(|w| u64::from_le_bytes(two[9 + 8 * w..17 + 8 * w].try_into().unwrap()))
            .collect();
        assert_eq!(selection[0], 1 << 5);
        assert_eq!(&two[73..], 1.0f32.to_le_bytes());

        values[6] = 7.0;
        let mut all = Vec::new();
        put_values(&mut all, &values, &active, None, true);
        assert_eq!(all[0], 6);
        assert_eq!(all.len(), 1 + 2 * 512);
    }

    #[test]
    fn a_tree_answers_from_leaves_tiles_and_background() {
        let mut tree = Tree::new(3.0f32);
        let mut leaf = Leaf::filled(-3.0);
        leaf.set(leaf_offset([9, 1, 2]), 0.5, true);
        tree.insert_leaf([8, 0, 0], leaf);
        tree.set_tile([0, 0, 0], 3, -3.0);
        tree.set_tile([4096, 0, 0], 12, -3.0);
        assert_eq!(tree.value([9, 1, 2]), (0.5, true));
        assert_eq!(tree.value([9, 1, 3]), (-3.0, false));
        assert_eq!(tree.value([1, 1, 1]), (-3.0, false));
        assert_eq!(tree.value([5000, 1, 1]), (-3.0, false));
        assert_eq!(tree.value([-1, 1, 1]), (3.0, false));
        assert_eq!(tree.active_voxel_count(), 1);
        assert_eq!(tree.active_bbox(), Some(([9, 1, 2], [9, 1, 2])));
    }
}
