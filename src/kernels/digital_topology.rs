//! Topology of a voxel set: its Euler characteristic, the voxels taken as closed unit cubes
//! (so that voxels sharing only an edge or a corner are joined: 26-connectivity).
//!
//! χ = V − E + F − C over the cubical complex the voxels cover: a lattice vertex, edge or face
//! counts once if any voxel touches it. Each is split evenly among the lattice vertices it
//! touches (an edge between two, a face among four, a cube among eight), so χ is a sum over the
//! lattice vertices of what their 2 × 2 × 2 neighbourhoods of voxels hold — one pass, no
//! memory beyond the mask (the local form of Lee, Poston and Rosenfeld's counting, 1991).
//! For a solid in one piece without cavities χ = 1 − g, g the genus of its surface.

/// The Euler characteristic of the voxels set in `mask` (i fastest over `dims`), joined across
/// faces, edges and corners.
pub fn euler_characteristic(mask: &[bool], dims: [usize; 3]) -> i64 {
    assert_eq!(mask.len(), dims.iter().product::<usize>());
    let [ni, nj, nk] = dims;
    let voxel = |i: usize, j: usize, k: usize| -> bool {
        // Lattice vertex (x, y, z) touches voxels x − 1 and x along each axis.
        i >= 1 && j >= 1 && k >= 1 && i <= ni && j <= nj && k <= nk && {
            let (i, j, k) = (i - 1, j - 1, k - 1);
            mask[i + ni * (j + nj * k)]
        }
    };
    // Eight times the sum, to stay in integers.
    let mut eightfold = 0i64;
    for z in 0..=nk {
        for y in 0..=nj {
            for x in 0..=ni {
                let mut window = [[[false; 2]; 2]; 2];
                let mut cubes = 0i64;
                for (a, plane) in window.iter_mut().enumerate() {
                    for (b, row) in plane.iter_mut().enumerate() {
                        for (c, v) in row.iter_mut().enumerate() {
                            *v = voxel(x + a, y + b, z + c);
                            cubes += i64::from(*v);
                        }
                    }
                }
                if cubes == 0 {
                    continue;
                }
                let at = |p: [usize; 3]| window[p[0]][p[1]][p[2]];
                // The six edges from the vertex: along `axis` to side `s`, touching the four
                // voxels on that side. The twelve faces at the vertex: across `axis`, in the
                // quadrant (u, w) of the other two, touching the voxel either side.
                let mut edges = 0i64;
                let mut faces = 0i64;
                for axis in 0..3 {
                    let (p, q) = ((axis + 1) % 3, (axis + 2) % 3);
                    for s in 0..2 {
                        let mut touched = false;
                        for u in 0..2 {
                            for w in 0..2 {
                                let mut cell = [0; 3];
                                cell[axis] = s;
                                cell[p] = u;
                                cell[q] = w;
                                touched |= at(cell);
                            }
                        }
                        edges += i64::from(touched);
                    }
                    for u in 0..2 {
                        for w in 0..2 {
                            let mut cell = [0; 3];
                            cell[p] = u;
                            cell[q] = w;
                            let before = at(cell);
                            cell[axis] = 1;
                            faces += i64::from(before || at(cell));
                        }
                    }
                }
                eightfold += 8 - 4 * edges + 2 * faces - cubes;
            }
        }
    }
    eightfold / 8
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask_of(dims: [usize; 3], inside: impl Fn(usize, usize, usize) -> bool) -> Vec<bool> {
        let mut mask = Vec::with_capacity(dims.iter().product());
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    mask.push(inside(i, j, k));
                }
            }
        }
        mask
    }

    #[test]
    fn a_block_is_one_a_ring_is_zero_and_a_hollow_block_is_two() {
        let dims = [7, 7, 7];
        let block = mask_of(dims, |i, j, k| {
            (1..6).contains(&i) && (1..6).contains(&j) && k == 3
        });
        assert_eq!(euler_characteristic(&block, dims), 1);
        let ring = mask_of(dims, |i, j, k| {
            (1..6).contains(&i) && (1..6).contains(&j) && k == 3 && !(i == 3 && j == 3)
        });
        assert_eq!(euler_characteristic(&ring, dims), 0);
        let hollow = mask_of(dims, |i, j, k| {
            let shell = |c: usize| (1..6).contains(&c);
            shell(i) && shell(j) && shell(k) && !(i == 3 && j == 3 && k == 3)
        });
        assert_eq!(euler_characteristic(&hollow, dims), 2);
    }

    #[test]
    fn voxels_meeting_at_a_corner_are_one_piece_and_close_a_ring_through_it() {
        let dims = [4, 4, 4];
        let corner = mask_of(dims, |i, j, k| {
            (i, j, k) == (1, 1, 1) || (i, j, k) == (2, 2, 2)
        });
        assert_eq!(euler_characteristic(&corner, dims), 1);
        // A ring of five voxels around (1, 1), three of its links only a shared edge.
        let ring = mask_of(dims, |i, j, k| {
            k == 1 && matches!((i, j), (0, 0) | (1, 0) | (2, 1) | (1, 2) | (0, 1))
        });
        assert_eq!(euler_characteristic(&ring, dims), 0);
    }
}
