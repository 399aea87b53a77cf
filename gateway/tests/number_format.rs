//! Register map 1.4: the number format (CFG_NUMBER_FORMAT, REGISTERS.md
//! "Value types"). Both forms pinned: the default f32 pairs, and
//! thousandths in 32-bit integers for PLCs that cannot pack floats, for
//! every f32 area of the map (OVERRIDE, ACT_JOINTS, ACT_POSE, a channel's
//! parameters and results), in both word orders, set over Modbus.
//! Virtual time (`hans_gateway::testkit`), as tests/behaviour.rs.

use embassy_time::Duration;
use hans_gateway::config::{Config, NumberFormat, WordOrder};
use hans_gateway::job::code;
use hans_gateway::registers as r;
use hans_gateway::testkit::world::{World, WorldConfig};

const CH0: u16 = r::CHANNEL_BASE;
const CH1: u16 = r::CHANNEL_BASE + r::CHANNEL_STRIDE;

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

fn world(number_format: NumberFormat, word_order: WordOrder) -> World {
    let mut w = World::new(WorldConfig {
        config: Config {
            number_format,
            word_order,
            ..WorldConfig::default().config
        },
        ..WorldConfig::default()
    });
    w.run_for(ms(300));
    w
}

/// The two registers of a 32-bit value, high word first.
fn words(v: u32) -> [u16; 2] {
    [(v >> 16) as u16, v as u16]
}

fn i32_at(w: &mut World, addr: u16) -> i32 {
    let v = w.read(addr, 2).expect("read");
    ((u32::from(v[0]) << 16) | u32::from(v[1])) as i32
}

fn wait_end(w: &mut World, ch: u16) -> u16 {
    let ended = w.run_until_cond(ms(3000), |w| {
        let s = w.reg(ch + r::CH_STATUS);
        s != 0 && s & r::ST_BUSY == 0
    });
    assert!(ended, "channel {ch} still busy");
    w.reg(ch + r::CH_STATUS)
}

fn last_sent(w: &World, name: &str) -> String {
    w.robot
        .log
        .iter()
        .rev()
        .find(|m| m.text.starts_with(name))
        .map(|m| m.text.clone())
        .unwrap_or_else(|| panic!("no {name} sent"))
}

#[test]
fn the_default_is_f32_and_the_register_says_so() {
    let mut w = world(NumberFormat::F32, WordOrder::HighFirst);
    assert_eq!(w.reg(r::STATUS_VERSION), 0x0105);
    assert_eq!(w.reg(r::CONFIG_NUMBER_FORMAT), 0);
    // J3 = 90.0 as f32, the pose's X = 420.0.
    assert_eq!(
        w.read(r::STATUS_JOINTS + 4, 2).unwrap(),
        words(90.0f32.to_bits())
    );
    assert_eq!(
        w.read(r::STATUS_POSE, 2).unwrap(),
        words(420.0f32.to_bits())
    );
    // The override is not known until set: NaN.
    assert_eq!(w.read(r::STATUS_OVERRIDE, 2).unwrap(), [0x7FC0, 0]);
}

#[test]
fn thousandths_are_set_over_modbus_and_apply_to_every_real_number() {
    let mut w = world(NumberFormat::F32, WordOrder::HighFirst);
    w.set(r::CONFIG_NUMBER_FORMAT, &[1]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    assert_eq!(w.reg(r::CONTROL_CONFIG_RESULT), 0, "applied and saved");
    assert_eq!(w.reg(r::CONFIG_NUMBER_FORMAT), 1);
    // Status: joints and pose in thousandths; the unknown override is
    // i32::MIN (0x8000 0x0000), not NaN.
    assert_eq!(i32_at(&mut w, r::STATUS_JOINTS + 4), 90_000);
    assert_eq!(i32_at(&mut w, r::STATUS_POSE), 420_000);
    assert_eq!(i32_at(&mut w, r::STATUS_POSE + 4), 445_000);
    assert_eq!(w.read(r::STATUS_OVERRIDE, 2).unwrap(), [0x8000, 0]);
    // Set the override 0.5 as 500 thousandths: the robot gets 0.500 (its
    // document's ratio), the status reads 500.
    w.set(CH0, &[0, code::SET_OVERRIDE, 1, 0, 0, 500]);
    w.set(CH0, &[1]);
    assert_eq!(wait_end(&mut w, CH0), r::ST_DONE);
    assert!(
        last_sent(&w, "SetOverride").contains(",0.500,"),
        "{}",
        last_sent(&w, "SetOverride")
    );
    assert_eq!(i32_at(&mut w, r::STATUS_OVERRIDE), 500);
    // Back to f32: the same registers read floats again.
    w.set(r::CONFIG_NUMBER_FORMAT, &[0]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    assert_eq!(
        w.read(r::STATUS_OVERRIDE, 2).unwrap(),
        words(0.5f32.to_bits())
    );
    // A value outside 0-1 is refused by the apply, as every setting.
    w.set(r::CONFIG_NUMBER_FORMAT, &[2]);
    assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[1]), Err(3));
    assert_eq!(w.reg(r::CONTROL_CONFIG_BAD_ADDR), r::CONFIG_NUMBER_FORMAT);
}

#[test]
fn parameters_in_thousandths_reach_the_robot_with_three_decimals() {
    let mut w = world(NumberFormat::Thousandths, WordOrder::HighFirst);
    // MoveRelJ: P0 axis 1 (an integer: 1000 thousandths), P1 -5.25°.
    let mut inputs = vec![0, code::MOVE_REL_J, 9, 0];
    for p in [1000i32, -5250] {
        inputs.extend(words(p as u32));
    }
    w.set(CH1, &inputs);
    // The parameters read back as written.
    assert_eq!(i32_at(&mut w, CH1 + r::CH_PARAMS + 2), -5250);
    w.set(CH1, &[1]);
    assert_eq!(wait_end(&mut w, CH1), r::ST_DONE);
    assert_eq!(last_sent(&w, "MoveRelJ"), "MoveRelJ,0,1,0,5.250,;");
    // An axis of 1.5 (1500) is not an integer: refused, nothing sent.
    let before = w.robot.log.len();
    w.set(CH1, &[0, code::MOVE_REL_J, 10, 0, 0, 1500, 0, 1000]);
    w.set(CH1, &[1]);
    assert_eq!(wait_end(&mut w, CH1), r::ST_ERROR);
    assert_eq!(i32_at(&mut w, CH1 + r::CH_ERROR_ID), 39501);
    assert!(!w.robot.log[before..]
        .iter()
        .any(|m| m.text.starts_with("MoveRelJ")));
}

#[test]
fn results_in_thousandths_and_unknown_until_given() {
    let mut w = world(NumberFormat::Thousandths, WordOrder::HighFirst);
    // No command has given results yet: unknown.
    assert_eq!(w.read(CH0 + r::CH_RESULTS, 2).unwrap(), [0x8000, 0]);
    w.set(CH0, &[0, code::READ_ACT_POS, 3, 0]);
    w.set(CH0, &[1]);
    assert_eq!(wait_end(&mut w, CH0), r::ST_DONE);
    // R2 = J3 = 90°, R6 = X = 420 mm, R9 = Rx = 180°.
    assert_eq!(i32_at(&mut w, CH0 + r::CH_RESULTS + 4), 90_000);
    assert_eq!(i32_at(&mut w, CH0 + r::CH_RESULTS + 12), 420_000);
    assert_eq!(i32_at(&mut w, CH0 + r::CH_RESULTS + 18), 180_000);
}

#[test]
fn the_word_order_applies_to_thousandths_too() {
    let mut w = world(NumberFormat::Thousandths, WordOrder::LowFirst);
    // 90000 = 0x0001_5F90: low word first.
    assert_eq!(w.read(r::STATUS_JOINTS + 4, 2).unwrap(), [0x5F90, 0x0001]);
    // A parameter written low word first, in two writes (low, then high).
    w.set(CH0 + r::CH_PARAMS + 2, &[0xEB7E]); // -5250 = 0xFFFF_EB7E
    w.set(CH0 + r::CH_PARAMS + 3, &[0xFFFF]);
    assert_eq!(w.read(CH0 + r::CH_PARAMS + 2, 2).unwrap(), [0xEB7E, 0xFFFF]);
}
