//! Host benchmark of the per-sample path (criterion): N = 12 and 24, models G and F, in f32
//! (the target scalar) and f64 (the host tools). The scenario (arrangement and analytic tumble)
//! is the one the QEMU instruction counts use.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use estimator_core::{Estimator, Model, Options, Real};

#[path = "../../firmware/qemu-bench/src/scenario.rs"]
#[allow(dead_code)]
mod scenario;

/// Samples pre-generated per benchmark (cycled).
const SAMPLES: usize = 2_000;

fn samples<T: Real>(channels: usize) -> (estimator_core::Arrangement<32>, Vec<(f64, Vec<T>)>) {
    let arr = scenario::arrangement::<32>(channels);
    let mut buf = vec![0.0f64; channels];
    let data = (0..SAMPLES)
        .map(|k| {
            let t = k as f64 * scenario::DT;
            scenario::outputs(&arr, t, 0.002, &mut buf);
            (t, buf.iter().map(|v| T::of(*v)).collect())
        })
        .collect();
    (arr, data)
}

fn bench_typed<T: Real>(c: &mut Criterion, scalar: &str) {
    let mut group = c.benchmark_group(format!("per_sample_{scalar}"));
    for channels in [12usize, 24] {
        for model in [Model::General, Model::FreeFloat] {
            let (arr, data) = samples::<T>(channels);
            let mut est = Estimator::<T, 32>::new(&arr, model, Options::default())
                .expect("scenario arrangement");
            // Warm up the tracker on the first samples so the benchmark measures steady state.
            for (t, p) in data.iter().take(100) {
                est.update(*t, p);
            }
            let mut k = 100;
            let mut t_off = 0.0;
            group.bench_with_input(
                BenchmarkId::new(model.name(), channels),
                &channels,
                |b, _| {
                    b.iter(|| {
                        if k == data.len() {
                            // Restart the record later in time so t keeps increasing.
                            k = 0;
                            t_off += SAMPLES as f64 * scenario::DT;
                        }
                        let (t, p) = &data[k];
                        k += 1;
                        black_box(est.update(t + t_off, black_box(p)).omega)
                    })
                },
            );
        }
    }
    group.finish();
}

fn per_sample(c: &mut Criterion) {
    bench_typed::<f32>(c, "f32");
    bench_typed::<f64>(c, "f64");
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(std::time::Duration::from_secs(2)).warm_up_time(std::time::Duration::from_millis(500));
    targets = per_sample
}
criterion_main!(benches);
