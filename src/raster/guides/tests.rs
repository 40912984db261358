use super::*;
use crate::raster::lod::rank;
use glam::Vec3;

/// Strands of `n` vertices each, from the roots given, straight along +y
/// with a bend that depends on the root (so their features differ).
fn strands(roots: &[Vec3], n: usize) -> Strands {
    let mut points = Vec::new();
    let mut offsets = vec![0u32];
    for (s, &r) in roots.iter().enumerate() {
        for j in 0..n {
            let u = j as f32 / (n - 1) as f32;
            let bend = 0.2 * rank(7 * s + 1);
            points.push(r + Vec3::new(bend * u * u, u, 0.1 * rank(7 * s + 2) * u));
        }
        offsets.push(points.len() as u32);
    }
    Strands {
        radii: vec![0.01; points.len()],
        points,
        offsets,
    }
}

fn random_roots(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|s| Vec3::new(rank(3 * s), rank(3 * s + 1), rank(3 * s + 2)))
        .collect()
}

fn every(fraction: f32) -> Guides {
    Guides {
        fraction,
        choice: GuideChoice::Every,
        terms: GuideTerms::All,
        given: None,
    }
}

/// 1. The grid search returns the same nearest members as comparing
///    against every member (distances equal; ties broken by index both
///    ways), for 400 queries against 97 members.
#[test]
fn t01_index_equals_brute_force() {
    let st = strands(&random_roots(500), 6);
    let feats: Vec<Feature> = (0..500).map(|s| feature(&st, s)).collect();
    let ids: Vec<u32> = (0..500).step_by(5).map(|s| s as u32).take(97).collect();
    let index = Index::new(&feats, &ids);
    for q in 0..400 {
        let mut brute: Vec<(f32, u32)> = ids
            .iter()
            .map(|&m| (dist2(&feats[q], &feats[m as usize]), m))
            .collect();
        brute.sort_by(|a, b| a.partial_cmp(b).unwrap());
        brute.truncate(NEIGHBOURS);
        assert_eq!(index.nearest(&feats[q]), brute, "query {q}");
        assert_eq!(index.nearest_one(&feats[q]), brute[0], "query {q}");
    }
}

/// 2. `every`: strands 0, k, 2k, ... with k = round(1/f); a guide's
///    vertices read themselves alone; every vertex's weights sum to 1.
#[test]
fn t02_every_kth_and_weights() {
    let st = strands(&random_roots(100), 5);
    for (f, k) in [(0.25, 4), (0.1, 10), (1.0 / 30.0, 30)] {
        let map = GuideMap::new(&st, &every(f));
        let want: Vec<u32> = (0..100).step_by(k).map(|s| s as u32).collect();
        assert_eq!(map.guides, want, "f = {f}");
        for s in 0..100 {
            for i in st.offsets[s] as usize..st.offsets[s + 1] as usize {
                let taps = map.taps(i);
                let total: f32 = taps.iter().map(|t| t.w).sum();
                // three weights, each rounded once in f32, then summed
                assert!(
                    (total - 1.0).abs() <= 4.0 * f32::EPSILON,
                    "vertex {i}: {total}"
                );
                if s % k == 0 {
                    assert_eq!(
                        taps[0],
                        Tap {
                            vertex: i as u32,
                            t: 0.0,
                            w: 1.0
                        }
                    );
                    assert!(taps[1..].iter().all(|t| t.w == 0.0));
                }
            }
        }
    }
}

/// 3. A value linear in the arc-length fraction along every guide comes
///    back exactly linear along every strand (to f32 rounding), whatever
///    the strands' vertex counts: the taps interpolate at the same
///    fraction of the guide's length.
#[test]
fn t03_interpolates_at_the_same_arc_fraction() {
    // Guides of 5 vertices, the others of 9, unevenly spaced.
    let roots = random_roots(40);
    let mut st = strands(&roots, 5);
    let other = strands(&roots, 9);
    let mut points = Vec::new();
    let mut offsets = vec![0u32];
    for s in 0..40 {
        let src = if s % 4 == 0 { &st } else { &other };
        let r = src.offsets[s] as usize..src.offsets[s + 1] as usize;
        let mut p: Vec<Vec3> = src.points[r].to_vec();
        if s % 4 != 0 {
            // uneven spacing along the same curve's chord
            for (j, q) in p.iter_mut().enumerate() {
                q.y += 0.03 * ((j * j) % 3) as f32;
            }
        }
        points.extend(p);
        offsets.push(points.len() as u32);
    }
    st = Strands {
        radii: vec![0.01; points.len()],
        points,
        offsets,
    };
    let map = GuideMap::new(&st, &every(0.25));
    let arc = arc_fractions(&st);
    let value = |i: usize| Vec3::new(arc[i], 2.0 * arc[i] + 1.0, -arc[i]);
    for i in 0..st.points.len() {
        let got = map.gather(i, value);
        let want = value(i);
        assert!(
            (got - want).abs().max_element() <= 1e-5,
            "vertex {i}: {got} vs {want}"
        );
    }
}

/// 4. `clusters` finds well-separated clumps: 12 clumps of 10 strands
///    with f = 1/10 give one guide per clump, and each strand takes its
///    nearest guide from its own clump.
#[test]
fn t04_clusters_find_clumps() {
    let mut roots = Vec::new();
    for c in 0..12 {
        let centre = Vec3::new(5.0 * (c % 4) as f32, 0.0, 5.0 * (c / 4) as f32);
        for j in 0..10 {
            roots.push(centre + 0.05 * Vec3::new(rank(31 * c + j), 0.0, rank(17 * c + j + 5)));
        }
    }
    // interleave the clumps so that every 10th strand misses some
    let order: Vec<usize> = (0..120).map(|i| (i % 12) * 10 + i / 12).collect();
    let roots: Vec<Vec3> = order.iter().map(|&i| roots[i]).collect();
    let st = strands(&roots, 4);
    let clump = |s: usize| order[s] / 10;
    let g = Guides {
        fraction: 0.1,
        choice: GuideChoice::Clusters,
        terms: GuideTerms::All,
        given: None,
    };
    let map = GuideMap::new(&st, &g);
    let mut clumps: Vec<usize> = map.guides.iter().map(|&s| clump(s as usize)).collect();
    clumps.sort_unstable();
    assert_eq!(clumps, (0..12).collect::<Vec<_>>());
    // every-10th guides miss clumps here: the test can tell the two apart
    let mut naive: Vec<usize> = GuideMap::new(&st, &every(0.1))
        .guides
        .iter()
        .map(|&s| clump(s as usize))
        .collect();
    naive.sort_unstable();
    naive.dedup();
    assert!(naive.len() < 12);
    for s in 0..120 {
        let first = map.taps(st.offsets[s] as usize)[0];
        let guide = (0..120)
            .find(|&g| (st.offsets[g]..st.offsets[g + 1]).contains(&first.vertex))
            .unwrap();
        assert_eq!(clump(guide), clump(s), "strand {s}");
    }
}

/// 5. `needed` marks exactly the guide vertices the used vertices read.
#[test]
fn t05_needed_vertices() {
    let st = strands(&random_roots(30), 6);
    let map = GuideMap::new(&st, &every(0.2));
    let mut used = vec![false; st.points.len()];
    used[st.offsets[7] as usize + 2] = true;
    let need = map.needed(Some(&used));
    let mut want = vec![false; st.points.len()];
    for t in map
        .taps(st.offsets[7] as usize + 2)
        .iter()
        .filter(|t| t.w > 0.0)
    {
        want[t.vertex as usize] = true;
        if t.t > 0.0 {
            want[t.vertex as usize + 1] = true;
        }
    }
    assert_eq!(need, want);
    assert!(need.iter().any(|&x| x));
    // every marked vertex belongs to a guide
    for (i, _) in need.iter().enumerate().filter(|x| *x.1) {
        let s = (0..30)
            .find(|&s| (st.offsets[s] as usize..st.offsets[s + 1] as usize).contains(&i))
            .unwrap();
        assert!(map.guides.contains(&(s as u32)));
    }
}

/// 6. Given guides: those strands (sorted, repeats and indices past the
///    strands dropped); renumbered for a subset of the strands, those not
///    kept dropped; none left: every strand is its own guide.
#[test]
fn t06_given_guides() {
    let st = strands(&random_roots(20), 4);
    let g = Guides {
        given: Some(vec![7, 3, 3, 19, 25].into()),
        ..Guides::default()
    };
    assert!(g.on());
    assert_eq!(GuideMap::new(&st, &g).guides, vec![3, 7, 19]);
    let sub = g.for_subset(&[1, 3, 4, 19]);
    assert_eq!(sub.given.as_deref(), Some(&[1u32, 3][..]));
    let none = g.for_subset(&[0, 1]);
    assert_eq!(
        GuideMap::new(&st, &none).guides,
        (0..20).collect::<Vec<u32>>()
    );
}
