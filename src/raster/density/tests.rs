use super::*;
use crate::fiber::karis::KarisParams;
use crate::raster::scene::{Camera, Cards, HairShading, Sphere};

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
    Scene {
        camera: Camera {
            position: Vec3::new(0.5, 0.5, 3.0),
            target: Vec3::splat(0.5),
            up: Vec3::Y,
            fov_y: 40.0,
            width: 16,
            height: 16,
        },
        lights: Vec::new(),
        environment: None,
        strands: Strands {
            radii: vec![r; points.len()],
            points,
            offsets,
        },
        cards: Cards::default(),
        spheres: Vec::new(),
        triangles: Vec::new(),
        hair: HairShading::Karis(KarisParams::default().build().unwrap()),
    }
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
        let path = c.at_fiber_behind(p, 0.0, Vec3::X, Vec3::Z);
        let alone = c.at_fiber(p, 0.0, Vec3::X, Vec3::Z);
        assert_eq!((path.n, path.clear), (alone.n, alone.clear));
        assert!(grid
            .fiber_count(light)
            .at_fiber_behind(p, 0.0, Vec3::X, Vec3::Z)
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
