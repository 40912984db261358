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
}

criterion_group!(benches, bench_chiang);
criterion_main!(benches);
