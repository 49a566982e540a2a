//! The wire bytes of every `SelectProfile` command, written down once: the
//! encoding of a profile must never change (a controller and a host built at
//! different times must agree), whatever the types behind it become. Each case
//! is the whole frame (delimiters, COBS, postcard, CRC-32), taken from the
//! encoder as it was before the profiles were built from `decoy_schema`'s
//! manoeuvres; the rates cover every length of the u16's varint.

use decoy_link::{Command, FrameDecoder, FrameError, HostMessage, MAX_WIRE_BYTES, Profile, encode};
use decoy_schema::Manoeuvre;

/// A SelectProfile command.
fn select(profile: Profile) -> HostMessage {
    HostMessage::Command(Command::SelectProfile(profile))
}

/// Every profile and its frame.
fn golden() -> Vec<(Profile, &'static [u8])> {
    vec![
        (Profile::Streamed, &[0, 3, 1, 1, 5, 100, 130, 152, 231, 0]),
        (
            Profile::builtin(Manoeuvre::Steady, 0),
            &[0, 8, 1, 1, 1, 242, 178, 159, 144, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Acceleration, 0),
            &[0, 8, 1, 1, 2, 72, 227, 150, 9, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 0),
            &[0, 4, 1, 1, 3, 5, 141, 129, 23, 179, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 1),
            &[0, 9, 1, 1, 3, 1, 27, 177, 16, 196, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 100),
            &[0, 9, 1, 1, 3, 100, 204, 36, 200, 249, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 127),
            &[0, 9, 1, 1, 3, 127, 32, 237, 173, 115, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 128),
            &[0, 10, 1, 1, 3, 128, 1, 76, 175, 60, 13, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 200),
            &[0, 10, 1, 1, 3, 200, 1, 65, 106, 156, 53, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 1000),
            &[0, 10, 1, 1, 3, 232, 7, 214, 235, 123, 73, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 1001),
            &[0, 10, 1, 1, 3, 233, 7, 151, 218, 96, 80, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 16383),
            &[0, 10, 1, 1, 3, 255, 127, 78, 150, 38, 18, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 16384),
            &[0, 11, 1, 1, 3, 128, 128, 1, 5, 71, 250, 248, 0],
        ),
        (
            Profile::builtin(Manoeuvre::PullUp, 65535),
            &[0, 11, 1, 1, 3, 255, 255, 3, 125, 108, 254, 225, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 0),
            &[0, 4, 1, 1, 4, 5, 74, 23, 86, 252, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 1),
            &[0, 9, 1, 1, 4, 1, 220, 39, 81, 139, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 100),
            &[0, 9, 1, 1, 4, 100, 11, 178, 137, 182, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 127),
            &[0, 9, 1, 1, 4, 127, 231, 123, 236, 60, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 128),
            &[0, 10, 1, 1, 4, 128, 1, 201, 185, 115, 8, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 200),
            &[0, 10, 1, 1, 4, 200, 1, 196, 124, 211, 48, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 1000),
            &[0, 10, 1, 1, 4, 232, 7, 83, 253, 52, 76, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 1001),
            &[0, 10, 1, 1, 4, 233, 7, 18, 204, 47, 85, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 16383),
            &[0, 10, 1, 1, 4, 255, 127, 203, 128, 105, 23, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 16384),
            &[0, 11, 1, 1, 4, 128, 128, 1, 188, 127, 45, 101, 0],
        ),
        (
            Profile::builtin(Manoeuvre::Turn, 65535),
            &[0, 11, 1, 1, 4, 255, 255, 3, 196, 84, 41, 124, 0],
        ),
    ]
}

/// Decodes every frame of `wire`.
fn decode(wire: &[u8]) -> Vec<Result<HostMessage, FrameError>> {
    let mut decoder = FrameDecoder::new();
    let mut out = Vec::new();
    decoder.push_slice(wire, |frame| out.push(frame));
    out
}

/// The frame of a hand-made postcard payload (its CRC appended).
fn frame_of(payload: &[u8]) -> Vec<u8> {
    let mut raw = payload.to_vec();
    raw.extend_from_slice(&decoy_link::crc32(payload).to_le_bytes());
    let mut out = vec![0u8; raw.len() + raw.len() / 254 + 3];
    let n = cobs::encode(&raw, &mut out[1..]);
    out.truncate(n + 2);
    out[n + 1] = 0;
    out
}

#[test]
fn every_profile_encodes_to_its_golden_bytes() {
    for (profile, bytes) in golden() {
        let mut wire = [0u8; MAX_WIRE_BYTES];
        let n = encode(&select(profile), &mut wire).unwrap();
        assert_eq!(&wire[..n], bytes, "{profile:?}");
    }
}

#[test]
fn every_golden_frame_decodes_to_its_profile() {
    for (profile, bytes) in golden() {
        assert_eq!(decode(bytes), vec![Ok(select(profile))], "{profile:?}");
    }
}

/// Payloads that are no profile: an index past the last variant, a rate-less
/// profile with a rate, a profile with a rate but none given.
#[test]
fn malformed_profiles_are_rejected() {
    for payload in [
        &[1u8, 1, 5][..],
        &[1, 1, 200, 1],
        &[1, 1, 1, 0],
        &[1, 1, 0, 7],
        &[1, 1, 3],
        &[1, 1, 4],
        &[1, 1, 4, 255, 255, 4],
    ] {
        assert_eq!(
            decode(&frame_of(payload)),
            vec![Err(FrameError::Decode)],
            "{payload:?}"
        );
    }
}

/// A profile's number is its variant index on the wire, and a manoeuvre without
/// a rate has none to carry.
#[test]
fn the_variant_index_is_the_profile_code() {
    for (profile, _) in golden() {
        let payload = postcard::to_allocvec(&select(profile)).unwrap();
        assert_eq!(u16::from(payload[2]), profile.code(), "{profile:?}");
        assert_eq!(
            profile.manoeuvre().map(|m| m.profile_code()).unwrap_or(0),
            profile.code()
        );
    }
    assert_eq!(
        Profile::builtin(Manoeuvre::Steady, 100),
        Profile::builtin(Manoeuvre::Steady, 0)
    );
    assert_eq!(
        Profile::builtin(Manoeuvre::Turn, 100).manoeuvre(),
        Some(Manoeuvre::Turn)
    );
}
