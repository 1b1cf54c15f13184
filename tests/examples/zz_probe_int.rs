use e2e_tests::faults::{fault_run, kinds, layout};
fn main() {
    let mut sc = layout(8014);
    let part = 2;
    let faulty = &sc.parts[part];
    let (name, spec) = kinds(
        sc.channel_noise(faulty),
        faulty.noise_density.unwrap_or(0.0),
    )
    .pop()
    .unwrap();
    let bursts = [
        (2.6888569788720007, 2.9888569788720005),
        (8.989014835001695, 9.289014835001696),
        (17.217074349312625, 17.517074349312626),
    ];
    for (a, b) in bursts {
        let mut f = spec.clone();
        f.part = sc.parts[part].name.clone();
        f.start = a;
        f.end = Some(b);
        sc.faults.push(f);
    }
    sc.duration = 20.517;
    eprintln!("{name}");
    let r = fault_run(&sc, Some((part, bursts[0].0, bursts[2].1)));
    eprintln!(
        "wrong {} excluded_after {:?}",
        r.wrong_excluded, r.excluded_after
    );
}
