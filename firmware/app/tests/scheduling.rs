//! The application's timing under commands: the estimate never waits for the identification
//! task, the spacecraft time sets the correlation, changes built in the background complete
//! once in force, and random commands, sets and builds keep every command answered.

mod common;

use ballisto_fw::app::{App, Mode};
use ballisto_fw::config::tetra;
use ballisto_fw::identification::SET_QUEUE;
use ballisto_fw::sampler::HealthBoard;
use ballisto_fw::telemetry::Telemetry;
use ballisto_link::decode::{Decoded, Report};
use ballisto_link::{service, subtype, ChannelSet, EventId, FailureCode};
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use estimator_core::Model;
use futures::executor::block_on;

use common::*;

/// The window's work is the identification task's, below the estimate: with the task stalled
/// every set is still estimated and reported at once; the sets beyond the task's queue are lost
/// to the window and counted in its summary (`not_covered`); an order beyond the queue and a
/// second solve before the first is answered are refused as busy; once the task runs, the
/// solution is reported. A unit without the task refuses the window by name.
#[test]
fn the_estimate_never_waits_for_the_identification_task() {
    use ballisto_link::verification::not_ready;
    let b = service::BALLISTOMETER;
    let busy = Some((FailureCode::NotReady, not_ready::IDENTIFICATION_BUSY));
    let last = |r: &[Decoded]| verification(r.last().unwrap());
    let motion = |r: &[Decoded]| {
        r.iter()
            .filter(|p| matches!(p.report, Report::Motion(_)))
            .count()
    };
    let mut u = Unit::new();
    u.identifying = false;
    let r = u.command(&tc(
        b,
        subtype::START_IDENTIFICATION,
        &start_data(1, 50, 4_000),
        90,
    ));
    assert_eq!(last(&r).0, subtype::COMPLETED);
    // 40 sets while the task does nothing: each estimated and reported.
    let before = u.all().len();
    u.sets(40);
    assert_eq!(motion(&u.all()[before..]), 40);
    let pts = |from: u64| -> Vec<u8> {
        let p: Vec<_> = (0..4)
            .map(|i| (from + i * 50_000_000, [0.0f32, 0.0, 0.5]))
            .collect();
        reference_data(&p)
    };
    // The start and one batch fill the task's two order slots; the next batch is refused.
    let r = u.command(&tc(b, subtype::REFERENCE_RATE, &pts(0), 91));
    assert_eq!(last(&r).0, subtype::COMPLETED);
    let r = u.command(&tc(b, subtype::REFERENCE_RATE, &pts(200_000_000), 92));
    assert_eq!(last(&r), (subtype::NOT_COMPLETED, busy));
    // The task runs again: the rest of the window goes through.
    u.identifying = true;
    u.identification_task();
    for (seq, batch) in (93..).zip(1..10u64) {
        u.sets(20);
        u.command(&tc(
            b,
            subtype::REFERENCE_RATE,
            &pts(batch * 200_000_000),
            seq,
        ));
    }
    // A solve asked while the task is stalled; a second one is busy.
    u.identifying = false;
    let r = u.command(&tc(b, subtype::REPORT_IDENTIFICATION, &[], 110));
    assert_eq!(
        r.iter().map(verification).collect::<Vec<_>>(),
        vec![(subtype::ACCEPTED, None)]
    );
    let r = u.command(&tc(b, subtype::REPORT_IDENTIFICATION, &[], 111));
    assert_eq!(last(&r), (subtype::NOT_COMPLETED, busy));
    let before = u.all().len();
    u.sets(1);
    u.identifying = true;
    u.identification_task();
    let r = u.all()[before..].to_vec();
    let summary = summary_in(&r).expect("the summary once the task has solved");
    assert!(
        summary.not_covered >= (40 - SET_QUEUE) as u32,
        "the sets lost on the way are counted: {summary:?}"
    );
    assert!(summary.sets > 100, "{summary:?}");

    // No identification task: the window is refused by name.
    let cfg = config();
    let mut app = App::new(&cfg, Mode::Operate).unwrap();
    let mut tm = Telemetry::new(Capture::default());
    block_on(app.boot(0, &mut tm));
    let raw = tc(
        b,
        subtype::START_IDENTIFICATION,
        &start_data(1, 50, 4_000),
        5,
    );
    block_on(app.on_incoming(&incoming(&raw), 0, &mut tm));
    let r = packets(&tm.link().0);
    assert_eq!(
        last(&r),
        (
            subtype::NOT_COMPLETED,
            Some((FailureCode::NotReady, not_ready::NO_IDENTIFICATION_TASK))
        )
    );
}

/// TC[9,128] correlates the unit's time to the spacecraft's: the boot's spacecraft time
/// (given minus the unit's time at reception) is in housekeeping from then on; a time before
/// the unit's own time since boot is refused with its reason and changes nothing.
#[test]
fn the_spacecraft_time_sets_the_time_correlation() {
    use ballisto_link::cuc::cuc_ticks;
    use ballisto_link::verification::not_ready;
    let mut u = Unit::new();
    u.sets(10);
    let boot = |u: &Unit| u.app.housekeeping(0).boot.expect("format 2 housekeeping").1;
    assert!(!boot(&u).set, "not correlated before the command");
    let cuc = |ticks: u64| ticks.to_be_bytes()[1..].to_vec();
    let received = 2_500_000_000; // ns after boot
                                  // 1000.5 s of spacecraft time at reception.
    let spacecraft = (1000 << 24) + (1 << 23);
    let refused = u.command_at(
        &tc(
            service::TIME,
            subtype::SET_TIME,
            &cuc(cuc_ticks(received) - 1),
            1,
        ),
        received,
    );
    assert_eq!(verification(&refused[0]), (subtype::ACCEPTED, None));
    assert_eq!(
        verification(refused.last().unwrap()),
        (
            subtype::NOT_COMPLETED,
            Some((FailureCode::NotReady, not_ready::TIME_BEFORE_BOOT))
        )
    );
    assert!(!boot(&u).set, "a refused time changes nothing");
    let r = u.command_at(
        &tc(service::TIME, subtype::SET_TIME, &cuc(spacecraft), 2),
        received,
    );
    assert_eq!(verification(r.last().unwrap()), (subtype::COMPLETED, None));
    let time = boot(&u);
    assert!(time.set);
    assert!((time.epoch_seconds() - 998.0).abs() < 1e-6, "{time:?}");
    // Housekeeping carries it on the link.
    let r = u.command(&tc(
        service::HOUSEKEEPING,
        subtype::HK_ONE_SHOT,
        &[1, 0, 2],
        3,
    ));
    let Report::Housekeeping(h) = &r[1].report else {
        panic!("no housekeeping: {:?}", r[1]);
    };
    assert_eq!(h.boot.map(|b| b.1), Some(time));
    // A wrong length is refused at acceptance.
    let short = u.command(&tc(service::TIME, subtype::SET_TIME, &[0; 6], 4));
    assert_eq!(
        verification(&short[0]),
        (subtype::NOT_ACCEPTED, Some((FailureCode::DataLength, 7)))
    );
}

/// With the builder task (a board without a double-precision FPU) a commanded
/// change is accepted at once and completed at the first set after its configuration is built
/// — the event with it — while the estimates go on (the channel on its way out read as
/// missing: flagged predictions, finite); another configuration command meanwhile is refused
/// as not ready. A refused change completes as refused, nothing changed. A channel back in to
/// the configuration set aside is swapped in and completed at once.
#[test]
fn commanded_changes_built_in_the_background_complete_once_in_force() {
    use ballisto_fw::estimation::Builds;
    use ballisto_link::verification::not_ready;
    use std::future::Future;
    use std::task::{Context, Poll};
    let builds: &'static Builds = Box::leak(Box::new(Builds::background()));
    let mut u = Unit::with(tetra());
    u.app.attach_builds(builds);
    u.sets(10);
    let mut builder = Box::pin(builds.run());
    let waker = futures::task::noop_waker();
    let mut cx = Context::from_waker(&waker);
    let b = service::BALLISTOMETER;
    let since = |u: &mut Unit, n: usize| u.all()[n..].to_vec();

    let r = u.command(&tc(b, subtype::EXCLUDE, &[3], 1));
    assert_eq!(r.len(), 1, "accepted, not completed yet: {r:?}");
    assert_eq!(verification(&r[0]), (subtype::ACCEPTED, None));
    let n = u.all().len();
    u.sets(5);
    let waiting: Vec<_> = since(&mut u, n)
        .into_iter()
        .filter_map(|p| match p.report {
            Report::Motion(m) => Some(m.estimate),
            _ => None,
        })
        .collect();
    assert_eq!(waiting.len(), 5, "an estimate every set");
    for e in &waiting {
        assert!(e.flags.has(estimator_core::Flags::INPUT_INVALID));
        assert!(e.omega.iter().chain(e.sigma0.iter()).all(|v| v.is_finite()));
    }
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0));
    assert_eq!(u.app.estimation().estimator().model(), Model::General);

    let r = u.command(&tc(b, subtype::SET_MODEL, &[1], 2));
    assert_eq!(verification(&r[0]), (subtype::ACCEPTED, None));
    assert_eq!(
        verification(r.last().unwrap()),
        (
            subtype::NOT_COMPLETED,
            Some((FailureCode::NotReady, not_ready::CONFIGURATION_BUSY))
        )
    );

    assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
    let n = u.all().len();
    u.sets(1);
    let r = since(&mut u, n);
    assert!(
        r.iter().any(|p| matches!(p.report, Report::Event(e)
            if e.id == EventId::ChannelsCommanded && e.a == 0 && e.b == 1 << 3)),
        "{r:?}"
    );
    assert!(
        r.iter().any(|p| matches!(&p.report, Report::Verification(v)
            if v.subtype == subtype::COMPLETED && v.request.sequence & 0x3FFF == 1)),
        "{r:?}"
    );
    let e = u.app.estimation();
    assert_eq!(e.excluded_channels(), ChannelSet(1 << 3));
    assert_eq!(e.estimator().model(), Model::FreeFloat, "eleven channels");

    // A model change, then the channel back: each completed once built.
    let r = u.command(&tc(b, subtype::SET_MODEL, &[1], 3));
    assert_eq!(r.len(), 1, "{r:?}");
    u.sets(3);
    assert_eq!(u.app.estimation().model(), Model::General, "not yet");
    assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
    let n = u.all().len();
    u.sets(1);
    let r = since(&mut u, n);
    let model_f = ballisto_link::ModelCode::from(Model::FreeFloat) as u32;
    assert!(
        r.iter().any(|p| matches!(p.report, Report::Event(e)
            if e.id == EventId::Reconfigured && e.a == 12 && e.b == model_f)),
        "{r:?}"
    );
    assert_eq!(u.app.estimation().model(), Model::FreeFloat);

    // Eight channels would be left: refused once built, nothing changed.
    for (seq, c) in [(4u16, 0u8), (5, 1)] {
        u.command(&tc(b, subtype::EXCLUDE, &[c], seq));
        assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
        u.sets(1);
    }
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0b1011));
    u.command(&tc(b, subtype::EXCLUDE, &[2], 6));
    assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
    let n = u.all().len();
    u.sets(1);
    let r = since(&mut u, n);
    assert!(
        r.iter().any(|p| matches!(&p.report, Report::Verification(v)
            if v.subtype == subtype::NOT_COMPLETED && v.request.sequence & 0x3FFF == 6
                && matches!(v.failure, Some((FailureCode::Refused, _))))),
        "{r:?}"
    );
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0b1011));
    let n = u.all().len();
    u.sets(2);
    assert!(since(&mut u, n).iter().all(|p| match p.report {
        Report::Motion(m) => !m.estimate.flags.has(estimator_core::Flags::INPUT_INVALID),
        _ => true,
    }));

    // A channel back in, to the configuration set aside when it went out: swapped in at once,
    // completed with the command, nothing asked of the builder.
    let r = u.command(&tc(b, subtype::INCLUDE, &[1], 7));
    assert_eq!(verification(r.last().unwrap()), (subtype::COMPLETED, None));
    assert!(
        r.iter().any(|p| matches!(p.report, Report::Event(e)
            if e.id == EventId::ChannelsCommanded && e.a == 0b1011 && e.b == 0b1001)),
        "{r:?}"
    );
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0b1001));
    assert!(!builds.build_now(), "nothing was built");
}

/// Issue 17, the builder's state machine under any order of events: random configuration
/// commands (exclude, include, model, a shifted arrangement), sample sets with part 3 dropping
/// out and back, and builds at random moments. Every configuration command accepted gets
/// exactly one completion or failure report; the estimates stay finite;
/// and once the builder has caught up and the part is back, the channels out are exactly the
/// ones the completed commands left out.
#[test]
fn random_commands_sets_and_builds_keep_every_command_answered() {
    use ballisto_fw::estimation::Builds;
    let mut rnd = xorshift(0x9E37_79B9_7F4A_7C15);
    let b = service::BALLISTOMETER;
    for run in 0..12 {
        let builds: &'static Builds = Box::leak(Box::new(Builds::background()));
        let mut u = Unit::with(tetra());
        u.app.attach_builds(builds);
        let data = shifted_arrangement(&u.cfg, 0.002);
        let mut sent: Vec<u16> = Vec::new();
        let mut seq = 1u16;
        for step in 0..400 {
            match rnd() % 10 {
                0 | 1 => {
                    let c = (rnd() % 12) as u8;
                    let st = if rnd().is_multiple_of(2) {
                        subtype::EXCLUDE
                    } else {
                        subtype::INCLUDE
                    };
                    u.command(&tc(b, st, &[c], seq));
                    sent.push(seq);
                    seq += 1;
                }
                2 => {
                    u.command(&tc(b, subtype::SET_MODEL, &[(rnd() % 2) as u8], seq));
                    sent.push(seq);
                    seq += 1;
                }
                3 => {
                    u.command(&tc(b, subtype::LOAD_ARRANGEMENT, &data, seq));
                    sent.push(seq);
                    seq += 1;
                }
                4..=6 => {
                    builds.build_now();
                }
                _ => {}
            }
            // Part 3 silent now and then (the sets of `set` carry every part).
            let s = set(&u.cfg, u.k);
            let mut s = s;
            if (step / 40) % 3 == 1 {
                s.parts[3] = None;
            }
            let board = HealthBoard::<NoopRawMutex>::new();
            board.publish(health(&u.cfg));
            block_on(u.app.on_set(&s, &board, &mut u.tm));
            u.k += 1;
        }
        // Catch up: the part back, the builder free to finish.
        for _ in 0..300 {
            builds.build_now();
            u.sets(1);
        }
        let all = u.all();
        let mut answered: Vec<u16> = Vec::new();
        for p in &all {
            match &p.report {
                Report::Verification(v) if v.subtype != subtype::ACCEPTED => {
                    answered.push(v.request.sequence & 0x3FFF);
                }
                Report::Motion(m) => {
                    let e = &m.estimate;
                    assert!(
                        e.omega.iter().chain(e.sigma0.iter()).all(|v| v.is_finite()),
                        "run {run}: {e:?}"
                    );
                }
                _ => {}
            }
        }
        // A command refused as busy is answered before the one being built.
        answered.sort_unstable();
        assert_eq!(answered, sent, "run {run}: one answer per command");
        assert!(!u.app.estimation().order_awaited(), "run {run}");
        assert_eq!(
            u.app.estimation().excluded_channels(),
            u.app.estimation().commanded(),
            "run {run}: only the commanded channels out once the part is back"
        );
        // Every channel back by command, then one out: the commands are what is in force.
        let step = |u: &mut Unit, st: u8, c: u8, seq: u16| {
            u.command(&tc(b, st, &[c], seq));
            builds.build_now();
            u.sets(1);
        };
        for c in 0..12u8 {
            if u.app.estimation().commanded().contains(usize::from(c)) {
                step(&mut u, subtype::INCLUDE, c, seq);
                seq += 1;
            }
        }
        assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0));
        let c = (run % 12) as u8;
        step(&mut u, subtype::EXCLUDE, c, seq);
        let e = u.app.estimation();
        assert_eq!(e.commanded(), ChannelSet(1 << c), "run {run}");
        assert_eq!(e.excluded_channels(), ChannelSet(1 << c), "run {run}");
    }
}
