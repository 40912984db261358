//! Criterion benchmarks of the fiber kernels (single thread, per pair).
//! Run: `cargo bench --bench fiber`. The side-by-side comparison with
//! Mitsuba lives in `benches/bench_bsdf.py`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hairshade::fiber::{ChiangHair, ChiangParams, I0Mode};
use std::hint::black_box;

fn directions(n: usize, seed: u64) -> Vec<[f64; 3]> {
    // xorshift64*, uniform on the sphere
    let mut s = seed;
    let mut next = move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545F4914F6CDD1D) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let z = 2.0 * next() - 1.0;
            let phi = std::f64::consts::TAU * next();
            let r = (1.0 - z * z).sqrt();
            [r * phi.cos(), z, r * phi.sin()]
        })
        .collect()
}

fn bench_chiang(c: &mut Criterion) {
    let n = 4096;
    let wi = directions(n, 1);
    let wo = directions(n, 2);
    let wi32: Vec<[f32; 3]> = wi.iter().map(|v| v.map(|x| x as f32)).collect();
    let wo32: Vec<[f32; 3]> = wo.iter().map(|v| v.map(|x| x as f32)).collect();
    let mut g = c.benchmark_group("chiang");
    g.throughput(Throughput::Elements(n as u64));
    for (name, mode) in [("exact", I0Mode::Exact), ("mitsuba", I0Mode::Mitsuba)] {
        let p = ChiangParams {
            i0: mode,
            ..Default::default()
        };
        let m64: ChiangHair<f64> = p.build().unwrap();
        let m32: ChiangHair<f32> = p.build().unwrap();
        g.bench_function(format!("eval_f64_{name}"), |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for (a, o) in wi.iter().zip(&wo) {
                    acc += m64.eval(black_box(a), black_box(o))[0];
                }
                acc
            })
        });
        g.bench_function(format!("eval_f32_{name}"), |b| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (a, o) in wi32.iter().zip(&wo32) {
                    acc += m32.eval(black_box(a), black_box(o))[0];
                }
                acc
            })
        });
    }
    g.finish();
    // The vector kernel (f32, exact I0) at each SIMD level, batch of 2^16
    // pairs on every thread, beside the scalar f32 kernel on the same batch.
    use hairshade::batch::{chiang_eval_simd, map_pairs_rgb};
    use hairshade::simd::Level;
    let n = 1 << 16;
    let flat = |d: Vec<[f64; 3]>| {
        d.iter()
            .flat_map(|v| v.map(|x| x as f32))
            .collect::<Vec<f32>>()
    };
    let (wi, wo) = (flat(directions(n, 1)), flat(directions(n, 2)));
    let m: ChiangHair<f32> = ChiangParams::default().build().unwrap();
    let mut out = vec![0.0f32; 3 * n];
    let mut g = c.benchmark_group("chiang_batch");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("scalar", |b| {
        b.iter(|| map_pairs_rgb(black_box(&wi), &wo, &mut out, |a, o| m.eval(a, o)))
    });
    for level in [Level::Portable, Level::Avx2, Level::Avx512] {
        if level.min_with(Level::detect()) != level {
            continue;
        }
        g.bench_function(level.name(), |b| {
            b.iter(|| chiang_eval_simd(&m, black_box(&wi), &wo, &mut out, level))
        });
    }
    g.finish();
}

/// KarisHair f32, all lobes, batch of 2^16 pairs on every thread: the
/// scalar kernel beside the vector kernel at each SIMD level.
fn bench_karis(c: &mut Criterion) {
    use hairshade::batch::{karis_eval_simd, par_map};
    use hairshade::fiber::karis::KarisInputs;
    use hairshade::fiber::karis::{KarisHair, KarisParams, Transmittance};
    use hairshade::simd::Level;
    let n = 1 << 16;
    let flat = |d: Vec<[f64; 3]>| {
        d.iter()
            .flat_map(|v| v.map(|x| x as f32))
            .collect::<Vec<f32>>()
    };
    let (l, v) = (flat(directions(n, 1)), flat(directions(n, 2)));
    let t = [0.0f32, 1.0, 0.0];
    let inp = KarisInputs::directions(&l, &v, &t);
    let m: KarisHair<f32> = KarisParams::default().build().unwrap();
    let mut out = vec![0.0f32; 3 * n];
    let mut g = c.benchmark_group("karis");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("scalar", |b| {
        b.iter(|| {
            par_map::<f32, 3, _>(&mut out, |i| {
                let a = [l[3 * i], l[3 * i + 1], l[3 * i + 2]];
                let o = [v[3 * i], v[3 * i + 1], v[3 * i + 2]];
                m.eval(&a, &o, &t, &Transmittance::default())
            })
        })
    });
    for level in [Level::Portable, Level::Avx2, Level::Avx512] {
        if level.min_with(Level::detect()) != level {
            continue;
        }
        g.bench_function(level.name(), |b| {
            b.iter(|| karis_eval_simd::<false>(&m, black_box(&inp), &mut out, level))
        });
    }
    g.finish();
}

criterion_group!(benches, bench_chiang, bench_karis);
criterion_main!(benches);
