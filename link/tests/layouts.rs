//! The layouts: lengths as documented, telecommands built as spacepackets builds them and
//! accepted by the parser, frames that survive the line.

use ballisto_link::event::EVENT_LEN;
use ballisto_link::framing::{encode, max_encoded_len, Deframed, Deframer};
use ballisto_link::housekeeping::HOUSEKEEPING_LEN;
use ballisto_link::ids::TM_MAX;
use ballisto_link::motion::MOTION_LEN;
use ballisto_link::telecommand::{self, Command, Context, ACK_ACCEPTANCE, ACK_COMPLETION};
use ballisto_link::{service, subtype, Event, EventId, Housekeeping, Mode, MotionReport};
use estimator_core::Estimate;
use spacepackets::ecss::tc::{AckFlags, PusTcCreator, PusTcSecondaryHeader};
use spacepackets::ecss::{CreatorConfig, MessageTypeId};
use spacepackets::SpHeader;

#[test]
fn layouts_have_their_documented_lengths() {
    let mut buf = [0u8; TM_MAX];
    assert_eq!(
        Housekeeping::default().encode(&mut buf),
        Some(HOUSEKEEPING_LEN)
    );
    let m = MotionReport {
        k: 1,
        estimate: Estimate::default(),
        missing_parts: ballisto_link::PartSet(0),
        excluded_parts: ballisto_link::PartSet(0),
        excluded_channels: ballisto_link::ChannelSet(0),
        context: Some((Mode::Operate, ballisto_link::ModelCode::General)),
    };
    assert_eq!(m.encode(&mut buf), Some(MOTION_LEN));
    // Without its context a report is not encoded (only an old layout's decoder leaves it out).
    let bare = MotionReport { context: None, ..m };
    assert_eq!(bare.encode(&mut buf), None);
    let e = Event {
        id: EventId::Boot,
        a: 0,
        b: 0,
    };
    assert_eq!(e.encode(&mut buf), Some(EVENT_LEN));
    assert_eq!(m.encode(&mut buf[..MOTION_LEN - 1]), None);
}

/// `telecommand::build` gives the octets spacepackets' creator gives, and the parser accepts
/// them with the flags and the command.
#[test]
fn built_telecommands_are_spacepackets_octets_and_are_accepted() {
    for ack in [
        0,
        ACK_ACCEPTANCE,
        ACK_COMPLETION,
        ACK_ACCEPTANCE | ACK_COMPLETION,
    ] {
        let flags = AckFlags::builder()
            .with_acceptance(ack & ACK_ACCEPTANCE != 0)
            .with_start(false)
            .with_progress(false)
            .with_completion(ack & ACK_COMPLETION != 0)
            .build();
        let data = [1u8];
        let mut ours = [0u8; 64];
        let n = telecommand::build(
            &mut ours,
            77,
            ack,
            service::BALLISTOMETER,
            subtype::SET_MODE,
            &data,
        )
        .unwrap();
        let sp = SpHeader::new_for_unseg_tc(
            arbitrary_int::u11::new(ballisto_link::APID),
            arbitrary_int::u14::new(77),
            0,
        );
        let sec = PusTcSecondaryHeader::new(
            MessageTypeId::new(service::BALLISTOMETER, subtype::SET_MODE),
            flags,
            0,
        );
        let reference = PusTcCreator::new(sp, sec, &data, CreatorConfig::default())
            .to_vec()
            .unwrap();
        assert_eq!(&ours[..n], &reference[..], "ack {ack:#x}");
        let accepted = telecommand::parse(&ours[..n], Context { channels: 12 }).unwrap();
        assert_eq!(accepted.ack_acceptance, ack & ACK_ACCEPTANCE != 0);
        assert_eq!(accepted.ack_completion, ack & ACK_COMPLETION != 0);
        assert!(matches!(accepted.command, Command::SetMode(Mode::Operate)));
    }
    let mut small = [0u8; 12];
    assert_eq!(
        telecommand::build(
            &mut small,
            0,
            0,
            service::TEST,
            subtype::ARE_YOU_ALIVE,
            &[1]
        ),
        None
    );
}

/// Frames of the `cobs` crate: every packet comes back whole, zero-free between the
/// delimiters, within `max_encoded_len`, including runs of 254 non-zero octets.
#[test]
fn frames_survive_the_line() {
    let mut seed = 12345u32;
    let mut next = move || {
        seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        (seed >> 16) as u8
    };
    let mut d = Deframer::<{ max_encoded_len(800) }>::new();
    for len in (0..800).step_by(7).chain([253, 254, 255, 508, 509]) {
        for zeros in [true, false] {
            let packet: Vec<u8> = (0..len)
                .map(|_| if zeros { next() } else { next() | 1 })
                .collect();
            let mut frame = vec![0u8; max_encoded_len(len)];
            let n = encode(&packet, &mut frame).unwrap();
            assert_eq!((frame[0], frame[n - 1]), (0, 0));
            assert!(!frame[1..n - 1].contains(&0));
            let mut got = None;
            for &b in &frame[..n] {
                if let Deframed::Packet(k) = d.push(b) {
                    got = Some(d.packet(k).to_vec());
                }
            }
            if len == 0 {
                // An empty packet is a frame "01": it comes back empty.
                assert_eq!(got.as_deref(), Some(&[][..]));
            } else {
                assert_eq!(got.as_deref(), Some(&packet[..]), "len {len}");
            }
        }
    }
}
