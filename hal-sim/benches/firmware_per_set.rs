//! Host benchmark of the firmware's per-set path (criterion): the sampler reading the four
//! ADXL355 of `tetra-orbit` through hal-sim's register models plus the estimation task, per
//! sample set; and the estimation alone (`Estimation::process`, f32, N = 12).

use ballisto_fw::config::Alignment;
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use hal_sim::firmware_host::{firmware_config, run_firmware};
use hal_sim::scenario::Scenario;

/// Sample sets per run of the whole-firmware benchmark.
const SETS: u32 = 200;

fn bench(c: &mut Criterion) {
    let sc = Scenario::load("tetra-orbit").expect("named scenario");
    let loaded = sc
        .arrangement()
        .load("arrangement.toml")
        .expect("arrangement");
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).expect("config");

    // Estimation alone, on the sets the firmware recorded.
    let mut sets = Vec::new();
    run_firmware(&sc, &config, SETS, &mut |s, _, _| sets.push(*s)).expect("run");
    let mut group = c.benchmark_group("firmware");
    group.bench_function("estimation_per_set_tetra_f32", |b| {
        let mut est = ballisto_fw::estimation::Estimation::new(&config).expect("estimator");
        let mut i = 0usize;
        b.iter(|| {
            let m = est.process(black_box(&sets[i % sets.len()]));
            i += 1;
            if i.is_multiple_of(sets.len()) {
                est = ballisto_fw::estimation::Estimation::new(&config).expect("estimator");
            }
            black_box(m.estimate.omega)
        })
    });
    // Sampler (drivers against the register models) + estimation, per 200 sets.
    group.sample_size(20);
    group.bench_function("sampling_and_estimation_200_sets_tetra", |b| {
        b.iter(|| {
            let r = run_firmware(&sc, &config, SETS, &mut |_, m, _| {
                black_box(m.estimate.omega);
            })
            .expect("run");
            black_box(r.estimates)
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
