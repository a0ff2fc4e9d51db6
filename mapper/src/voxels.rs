//! The map: classified pixels lifted into 5 cm voxels, where each pixel brings the votes
//! its region got from the classifier's trees, and objects cut as connected voxels of one
//! class.

use std::collections::{BTreeMap, HashMap};

use crate::learn::Votes;

/// Side of a voxel in metres.
pub const VOXEL_M: f32 = 0.05;
/// Objects with fewer voxels stay in the map but not in the scene graph (a stray region's
/// votes, not a thing).
pub const GRAPH_MIN_VOXELS: usize = 20;

type Key = [i32; 3];

#[derive(Default)]
struct Cell {
    votes: BTreeMap<u32, u32>,
    rgb: [f64; 3],
    seen: u32,
}

/// Votes of labelled points, per voxel.
#[derive(Default)]
pub struct VoxelMap {
    cells: HashMap<Key, Cell>,
}

/// One object of the map: connected voxels of one class.
#[derive(Debug, Clone, PartialEq)]
pub struct MappedObject {
    /// Its class id.
    pub class: u32,
    /// Its voxels.
    pub voxels: usize,
    /// Centre of its box, metres.
    pub centre: [f64; 3],
    /// Extent of its box, metres.
    pub extent: [f64; 3],
    /// The mean colour its pixels showed, each channel in [0, 255].
    pub rgb: [f64; 3],
}

/// The map's points (one per voxel, at its centre), each point's object, and the objects.
#[derive(Debug, Clone, PartialEq)]
pub struct CutMap {
    /// Voxel centres, in the order of their keys.
    pub points: Vec<[f32; 3]>,
    /// The object of each point.
    pub object_ids: Vec<u32>,
    /// The objects, numbered by their first voxel.
    pub objects: Vec<MappedObject>,
}

impl VoxelMap {
    /// Add a point whose region the trees voted for as `votes` (class id to trees), and
    /// whose pixel showed `rgb` (each channel in [0, 1]). A region the trees were unsure of
    /// weighs in its voxels as unsure: its runner-up classes keep their votes.
    pub fn add(&mut self, point: [f32; 3], votes: &Votes, rgb: [f32; 3]) {
        let key = point.map(|c| (c / VOXEL_M).floor() as i32);
        let cell = self.cells.entry(key).or_default();
        for (&class, &trees) in votes {
            *cell.votes.entry(class).or_default() += trees;
        }
        for c in 0..3 {
            cell.rgb[c] += rgb[c] as f64 * 255.0;
        }
        cell.seen += 1;
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether no point was added.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Each voxel takes the class with the most votes of its points (ties to the lowest id), and
    /// 26-connected voxels of one class make an object.
    pub fn cut(&self) -> CutMap {
        let mut keys: Vec<Key> = self.cells.keys().copied().collect();
        keys.sort_unstable();
        let position: HashMap<Key, usize> = keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
        let class: Vec<u32> = keys.iter().map(|k| crate::majority(&self.cells[k].votes)).collect();
        let mut object_of = vec![u32::MAX; keys.len()];
        let mut objects = Vec::new();
        let mut stack = Vec::new();
        for start in 0..keys.len() {
            if object_of[start] != u32::MAX {
                continue;
            }
            let id = objects.len() as u32;
            object_of[start] = id;
            stack.push(start);
            let mut members = Vec::new();
            while let Some(i) = stack.pop() {
                members.push(i);
                for j in neighbours(keys[i]).filter_map(|k| position.get(&k).copied()) {
                    if object_of[j] == u32::MAX && class[j] == class[start] {
                        object_of[j] = id;
                        stack.push(j);
                    }
                }
            }
            objects.push(self.object(&keys, &members, class[start]));
        }
        let points = keys.iter().map(|k| k.map(|c| (c as f32 + 0.5) * VOXEL_M)).collect();
        CutMap { points, object_ids: object_of, objects }
    }

    fn object(&self, keys: &[Key], members: &[usize], class: u32) -> MappedObject {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let (mut rgb, mut seen) = ([0.0; 3], 0.0);
        for &m in members {
            let cell = &self.cells[&keys[m]];
            for c in 0..3 {
                lo[c] = lo[c].min(keys[m][c] as f64 * VOXEL_M as f64);
                hi[c] = hi[c].max((keys[m][c] + 1) as f64 * VOXEL_M as f64);
                rgb[c] += cell.rgb[c];
            }
            seen += cell.seen as f64;
        }
        MappedObject {
            class,
            voxels: members.len(),
            centre: std::array::from_fn(|c| (lo[c] + hi[c]) / 2.0),
            extent: std::array::from_fn(|c| hi[c] - lo[c]),
            rgb: rgb.map(|v| v / seen.max(1.0)),
        }
    }
}

fn neighbours(k: Key) -> impl Iterator<Item = Key> {
    (-1..=1).flat_map(move |dx| (-1..=1).flat_map(move |dy| (-1..=1).map(move |dz| [k[0] + dx, k[1] + dy, k[2] + dz]))).filter(move |n| *n != k)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One tree's vote for `class`.
    fn one(class: u32) -> Votes {
        Votes::from([(class, 1)])
    }

    #[test]
    fn voxels_take_the_majority_class_and_touching_voxels_of_a_class_are_one_object() {
        let mut map = VoxelMap::default();
        // A 3-voxel bar of class 4 along x, and one voxel of class 9 two voxels away.
        for x in 0..3 {
            map.add([x as f32 * VOXEL_M + 0.01, 0.01, 0.01], &one(4), [1.0, 0.0, 0.0]);
        }
        map.add([0.01, 0.01, 0.01], &one(9), [0.0, 0.0, 1.0]); // outvoted? no: a tie goes to the lower id
        map.add([5.0 * VOXEL_M + 0.01, 0.01, 0.01], &one(9), [0.0, 0.0, 1.0]);
        let cut = map.cut();
        assert_eq!(cut.points.len(), 4);
        assert_eq!(cut.object_ids, vec![0, 0, 0, 1]);
        assert_eq!(cut.objects[0].class, 4, "a tie goes to the lower class id");
        assert_eq!(cut.objects[0].voxels, 3);
        assert!((cut.objects[0].extent[0] - 0.15).abs() < 1e-6 && (cut.objects[0].centre[0] - 0.075).abs() < 1e-6);
        assert_eq!(cut.objects[1].class, 9);
        assert!((cut.objects[1].rgb[2] - 255.0).abs() < 1e-9);
        let red = cut.objects[0].rgb;
        assert!((red[0] - 3.0 * 255.0 / 4.0).abs() < 1e-9, "the colour its points showed: {red:?}");
    }

    #[test]
    fn diagonal_voxels_connect_and_classes_split_objects() {
        let mut map = VoxelMap::default();
        map.add([0.01, 0.01, 0.01], &one(2), [0.5; 3]);
        map.add([0.06, 0.06, 0.06], &one(2), [0.5; 3]);
        map.add([0.11, 0.11, 0.11], &one(3), [0.5; 3]);
        let cut = map.cut();
        assert_eq!(cut.objects.len(), 2);
        assert_eq!(cut.object_ids, vec![0, 0, 1]);
    }

    #[test]
    fn a_voxel_sums_the_trees_votes_of_its_points_so_sure_regions_outweigh_unsure_ones() {
        let mut map = VoxelMap::default();
        // Two points whose regions the trees called 5 by 34 to 30, and one called 7 by 60 to 4.
        map.add([0.01, 0.01, 0.01], &Votes::from([(5, 34), (7, 30)]), [0.5; 3]);
        map.add([0.02, 0.01, 0.01], &Votes::from([(5, 34), (7, 30)]), [0.5; 3]);
        map.add([0.03, 0.01, 0.01], &Votes::from([(7, 60), (5, 4)]), [0.5; 3]);
        // Class 5 names two of the three points, but class 7 has 120 votes to its 72.
        assert_eq!(map.cut().objects[0].class, 7);
    }
}
