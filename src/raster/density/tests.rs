use super::*;
use crate::raster::scene::Sphere;

/// A box [0, 1]³ of straight fibers along x, radius `r`, on a square
/// lattice of spacing `s` in (y, z): σ(d) = 2r|x̂ × d| / s² per unit
/// length.
fn lattice(r: f32, s: f32) -> Scene {
    let (mut points, mut offsets) = (Vec::new(), vec![0u32]);
    let rows = (1.0 / s) as usize;
    for j in 0..rows {
        for k in 0..rows {
            let (y, z) = ((j as f32 + 0.5) * s, (k as f32 + 0.5) * s);
            points.push(Vec3::new(0.0, y, z));
            points.push(Vec3::new(1.0, y, z));
            offsets.push(points.len() as u32);
        }
    }
    Scene::of_strands(Strands {
        radii: vec![r; points.len()],
        points,
        offsets,
    })
}

fn count(grid: &DensityGrid, d: Vec3, p: Vec3) -> f32 {
    let light = Light::Directional {
        direction: d.normalize(),
        intensity: Vec3::ONE,
        shadows: true,
    };
    grid.fiber_count(&light).at(p).n
}

// 01: the fiber count towards a directional light inside a box of
// parallel fibers is σ times the path length to the box's face, across
// the fibers straight and obliquely (which exercises the sweep's
// bilinear step between slices), and 0 along them. Tolerance: the
// trilinear splat spreads the fibers at the face over one voxel, which
// the trapezoid sweep integrates to within σ·voxel; inside, σ is
// uniform and the sweep exact up to f32 rounding.
#[test]
fn t01_count_is_sigma_times_path_length() {
    let (r, s) = (0.001f32, 0.005f32);
    let sigma = 2.0 * r / (s * s);
    let grid = DensityGrid::new(&lattice(r, s), 64).unwrap();
    let tol = sigma * grid.voxel;
    for z in [0.2f32, 0.4, 0.6, 0.8] {
        let p = Vec3::new(0.5, 0.5, z);
        let n = count(&grid, Vec3::Z, p);
        let want = sigma * (1.0 - z);
        assert!((n - want).abs() <= tol, "straight, z {z}: {n} vs {want}");
        // 45° towards −y: the path is √2 longer (it leaves through
        // the top face, y stays inside)
        let p = Vec3::new(0.5, 0.9, z);
        let n = count(&grid, Vec3::new(0.0, -1.0, 1.0), p);
        let want = sigma * (1.0 - z) * std::f32::consts::SQRT_2;
        assert!((n - want).abs() <= tol, "oblique, z {z}: {n} vs {want}");
        // along the fibers: none crossed
        let n = count(&grid, Vec3::X, Vec3::new(0.3, 0.5, z));
        assert!(n.abs() <= 1e-2 * sigma * 0.7, "along, z {z}: {n}");
    }
}

// 02: the grid's moments do not depend on the thread count (each
// voxel's sum is taken in strand order).
#[test]
fn t02_grid_independent_of_threads() {
    let scene = lattice(0.002, 0.02);
    let many = DensityGrid::new(&scene, 48).unwrap();
    // (other tests running meanwhile just run on one thread too)
    crate::threads::set_single_threaded(true);
    let one = DensityGrid::new(&scene, 48);
    crate::threads::set_single_threaded(false);
    assert_eq!(one.unwrap().moments, many.moments);
}

// 03: the count away from the light: for a directional light σ times
// the path length to the box's far face (the same tolerance as 01), for
// a point light the same along the line from the light, and with an
// opaque sphere in the box it ends at the sphere (σ times the distance
// to its surface; the sphere is marked by voxel centres, so within one
// voxel of it: σ·voxel more).
#[test]
fn t03_count_behind() {
    let (r, s) = (0.001f32, 0.005f32);
    let sigma = 2.0 * r / (s * s);
    let mut scene = lattice(r, s);
    let grid = DensityGrid::new(&scene, 64).unwrap();
    let tol = sigma * grid.voxel;
    let behind = |grid: &DensityGrid, light: &Light, p: Vec3| {
        let c = grid.fiber_count_with(light, true);
        let path = c.at_fiber_behind(p, 0.0);
        let alone = c.at_fiber(p, 0.0);
        assert_eq!((path.n, path.clear), (alone.n, alone.clear));
        assert!(grid
            .fiber_count(light)
            .at_fiber_behind(p, 0.0)
            .behind
            .is_none());
        path.behind.unwrap()
    };
    let dir = Light::Directional {
        direction: Vec3::Z,
        intensity: Vec3::ONE,
        shadows: true,
    };
    let point = Light::Point {
        position: Vec3::new(0.5, 0.5, 3.0),
        intensity: Vec3::ONE,
        shadows: true,
    };
    for z in [0.2f32, 0.5, 0.8] {
        let p = Vec3::new(0.5, 0.5, z);
        for light in [&dir, &point] {
            let m = behind(&grid, light, p);
            assert!((m - sigma * z).abs() <= tol, "z {z}: {m} vs {}", sigma * z);
        }
    }
    // an opaque sphere below: the count stops at its top
    scene.spheres.push(Sphere {
        center: Vec3::new(0.5, 0.5, 0.1),
        radius: 0.15,
        albedo: Vec3::ONE,
    });
    let grid = DensityGrid::new(&scene, 64).unwrap();
    for z in [0.5f32, 0.8] {
        let p = Vec3::new(0.5, 0.5, z);
        let want = sigma * (z - 0.25);
        for light in [&dir, &point] {
            let m = behind(&grid, light, p);
            assert!(
                (m - want).abs() <= 2.0 * tol,
                "sphere, z {z}: {m} vs {want}"
            );
        }
    }
}

// 04: the fibers baked cards stand for fill the grid as the same
// fibers drawn as strands do: moving every strand into the cards'
// fibers gives the same frame and the same moments, bit for bit.
#[test]
fn t04_card_fibers_fill_the_grid() {
    let strands = lattice(0.002, 0.02);
    let mut cards = lattice(0.002, 0.02);
    cards.cards.fibers = std::mem::take(&mut cards.strands);
    let (a, b) = (
        DensityGrid::new(&strands, 48).unwrap(),
        DensityGrid::new(&cards, 48).unwrap(),
    );
    assert_eq!((a.origin, a.voxel, a.dims), (b.origin, b.voxel, b.dims));
    assert_eq!(a.moments, b.moments);
    // and nothing without either
    cards.cards.fibers = Strands::default();
    assert!(DensityGrid::new(&cards, 48).is_none());
}

// 05: a lone fiber counts little of itself towards any light. Its own
// cross-section is splatted into the voxels around it: a ray leaving its
// axis along d crosses 2r|t × d| / voxel² of it per unit length over
// about voxel / (2|t × d|), so about r / voxel whatever the angle. A
// straight fiber along x, radius 0.1 voxel, at 10 places across a voxel
// (a second fiber away from the rays fixes the grid), 64 points along
// its middle, 7 angles from 10 to 90 degrees in three planes: its raw
// count, averaged along the fiber, measured 0.50-1.25 r / voxel (the
// mean over places 0.65 at right angles, 0.90 at 10 degrees), so
// `at_fiber` takes out r / voxel: what is left at any point is at most
// 0.6 r / voxel (measured 0.55), and over-subtraction only clamps at 0
// (in dense hair r / voxel is a small part of any count: about 0.01 for
// a head's fibers at the default grids). The share taken as
// r|t × d| / voxel (the crossing at right angles alone) left 1.37.
#[test]
fn t05_a_lone_fiber_counts_little_of_itself() {
    let mut worst = 0.0f32;
    for (yi, zi) in [
        (0, 0),
        (0, 1),
        (0, 2),
        (0, 3),
        (1, 1),
        (1, 2),
        (2, 2),
        (3, 3),
        (1, 3),
        (2, 3),
    ] {
        let (y, z) = (0.5 + yi as f32 / 240.0, 0.47 + zi as f32 / 240.0);
        let mut scene = lattice(0.001, 1.0);
        scene.strands.points = vec![
            Vec3::new(0.0, y, z),
            Vec3::new(1.0, y, z),
            Vec3::ZERO,
            Vec3::X,
        ];
        scene.strands.offsets = vec![0, 2, 4];
        let (_, voxel, _) = grid_frame(&scene, 64).unwrap();
        let r = 0.1 * voxel;
        scene.strands.radii = vec![r; 4];
        let grid = DensityGrid::new(&scene, 64).unwrap();
        for deg in [10.0f32, 20.0, 30.0, 45.0, 60.0, 75.0, 90.0] {
            let a = deg.to_radians();
            for plane in [Vec3::Y, Vec3::Z, (Vec3::Y + Vec3::Z).normalize()] {
                let d = Vec3::X * a.cos() + plane * a.sin();
                let c = grid.fiber_count(&Light::Directional {
                    direction: d,
                    intensity: Vec3::ONE,
                    shadows: true,
                });
                for k in 0..64 {
                    let p = Vec3::new(0.3 + 0.4 * k as f32 / 63.0, y, z);
                    assert!(c.at(p).n > 0.0);
                    worst = worst.max(c.at_fiber(p, r).n * voxel / r);
                }
            }
        }
    }
    println!("left: at most {worst:.3} r / voxel");
    assert!(worst <= 0.6, "{worst}");
}
