//! Typed values of the corpus's messages, family by family, through the
//! codec's structs (the corpus's `v:` lines check every value through the
//! `Visitor`; these check the public types a caller uses).

use std::path::Path;

use hans_codec::{
    request, Command, CommandId, Decimal, ErrorCode, FsmState, Got, ParseError, Reply, ReplyExpect,
    Request, Response, RobotId,
};
use hans_host_tests::corpus::{Corpus, Kind, Source, Vector};

fn corpus(file: &str) -> Corpus {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("vectors")
        .join(file);
    Corpus::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The `nth` vector (0-based) of `kind` and `source` in `section` of `file`.
fn vector(file: &str, section: &str, kind: Kind, source: Source, nth: usize) -> Vector {
    corpus(file)
        .vectors
        .into_iter()
        .filter(|v| v.section == section && v.kind == kind && v.source == source)
        .nth(nth)
        .unwrap_or_else(|| panic!("{file}: no {kind:?} {source:?} vector #{nth} in {section}"))
}

fn doc(section: &str, kind: Kind, nth: usize) -> String {
    vector("chapter4.txt", section, kind, Source::Doc, nth).text
}

fn d(s: &str) -> Decimal {
    Decimal::parse(s).expect("decimal literal")
}

fn req(text: &str) -> Request<'_> {
    Request::parse(text).unwrap_or_else(|e| panic!("{text}: {e}"))
}

fn ok<'a>(text: &'a str, expect: ReplyExpect) -> Response<'a> {
    match Reply::parse(text, expect) {
        Ok(Reply::Ok(r)) => r,
        other => panic!("{text}: {other:?}"),
    }
}

#[test]
fn initialisation_and_group() {
    let t = doc("4.1.1", Kind::Req, 0);
    let Request::OSCmd(r) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(r.cmd_type, 1);

    let t = doc("4.1.9", Kind::Ok, 0);
    let Response::ReadRobotModel(m) = ok(&t, ReplyExpect::of(CommandId::ReadRobotModel)) else {
        panic!("{t}")
    };
    assert_eq!(m.model, "5KG");

    let t = doc("4.2.1", Kind::Req, 0);
    let r = request::GrpEnable::parse(&t).expect("GrpEnable");
    assert_eq!(r.rbt_id, RobotId(0));
    let alias = vector("variants.txt", "4.2.1", Kind::Req, Source::Notes, 0).text;
    assert_eq!(alias, "GrpPowerOn,0,;");
    assert_eq!(req(&alias).command(), Some(CommandId::GrpEnable));
}

#[test]
fn scripts() {
    let t = doc("4.3.1", Kind::Req, 0);
    let Request::RunFunc(r) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(r.func_name, "Func_1");
    assert_eq!(r.params.iter().collect::<Vec<_>>(), ["55"]);
    let t = doc("4.3.1", Kind::Ok, 0);
    let Response::RunFunc(o) = ok(&t, r.expect()) else {
        panic!("{t}")
    };
    assert_eq!(o.func_name, "Func_1");
}

#[test]
fn electric_box() {
    let t = doc("4.4.1", Kind::Ok, 0);
    let Response::ReadBoxInfo(b) = ok(&t, ReplyExpect::of(CommandId::ReadBoxInfo)) else {
        panic!("{t}")
    };
    assert_eq!((b.connected, b.power_48v), (1, 1));
    assert_eq!(b.out_voltage.to_scaled(3), Some(48_000));
    assert_eq!(b.voltage_12v, None);
    let t = vector("variants.txt", "4.4.1", Kind::Ok, Source::Notes, 1).text;
    let Response::ReadBoxInfo(b) = ok(&t, ReplyExpect::of(CommandId::ReadBoxInfo)) else {
        panic!("{t}")
    };
    assert_eq!(b.voltage_12v, Some(d("12")));
    assert_eq!(b.current_12v.map(|c| c.to_f64()), Some(0.5));

    // ReadBoxDI,5,6,; asks for two bits: the reply must carry two values.
    let t = doc("4.4.3", Kind::Req, 2);
    let Request::ReadBoxDI(r) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(r.bits.as_slice(), [5, 6]);
    assert_eq!(r.expect().count, Some(2));
    let t = doc("4.4.3", Kind::Ok, 2);
    let Response::ReadBoxDI(o) = ok(&t, r.expect()) else {
        panic!("{t}")
    };
    assert_eq!(o.values.as_slice(), [0, 1]);

    let t = doc("4.4.11", Kind::Req, 1);
    let Request::SetBoxAO(a) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((a.channel, a.value, a.mode), (1, d("8.8"), 2));
}

#[test]
fn state_reads_and_settings() {
    let t = doc("4.5.8", Kind::Req, 0);
    let Request::SetMaxAcsRange(r) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(r.max[1], d("135"));
    assert_eq!(r.min[5], d("-360"));

    let t = doc("4.5.15", Kind::Ok, 0);
    let Response::ReadRobotState(s) = ok(&t, ReplyExpect::of(CommandId::ReadRobotState)) else {
        panic!("{t}")
    };
    assert_eq!((s.moving, s.enabled, s.error), (1, 1, 0));
    assert_eq!((s.powered, s.box_connected, s.in_position), (1, 1, 0));

    let t = doc("4.5.18", Kind::Ok, 0);
    let Response::ReadCurFSM(f) = ok(&t, ReplyExpect::of(CommandId::ReadCurFSM)) else {
        panic!("{t}")
    };
    assert_eq!(f.state, FsmState::ScriptRunning);

    let t = doc("4.5.16", Kind::Ok, 0);
    let Response::ReadCurWayPointID(w) = ok(&t, ReplyExpect::of(CommandId::ReadCurWayPointID))
    else {
        panic!("{t}")
    };
    assert_eq!(w.id, "64BDE6A1BCF9AEAC06670EC8D5431093");

    let t = doc("4.5.13", Kind::Ok, 0);
    let Response::ReadLinearMaxVel(l) = ok(&t, ReplyExpect::of(CommandId::ReadLinearMaxVel)) else {
        panic!("{t}")
    };
    assert_eq!(l.max_jerk.to_scaled(0), Some(10_000_000));
}

#[test]
fn positions_and_velocities() {
    let t = vector("chapter4.txt", "4.6.1", Kind::Ok, Source::Fixed, 0).text;
    let Response::ReadActPos(p) = ok(&t, ReplyExpect::of(CommandId::ReadActPos)) else {
        panic!("{t}")
    };
    assert_eq!(p.joints[0].to_f64(), 10.759);
    assert_eq!(p.pose[2], d("970.143"));
    assert!(p.ucs.iter().all(|v| v.is_zero()));

    let t = doc("4.6.6", Kind::Ok, 0);
    let Response::ReadActTcpVel(v) = ok(&t, ReplyExpect::of(CommandId::ReadActTcpVel)) else {
        panic!("{t}")
    };
    assert_eq!(v.velocity[0].to_scaled(3), Some(-1181));
    // `-0.000` keeps its sign and its decimals.
    assert!(v.velocity[3].is_sign_negative() && v.velocity[3].is_zero());
    assert_eq!(v.velocity[3].to_string(), "-0.000");
}

#[test]
fn coordinate_computations() {
    let t = vector("chapter4.txt", "4.7.3", Kind::Req, Source::Derived, 0).text;
    let Request::GetInverseKin(k) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(k.pose[0], d("420"));
    assert_eq!(k.reference[2], d("90"));
    let t = doc("4.7.3", Kind::Ok, 0);
    let Response::GetInverseKin(j) = ok(&t, k.expect()) else {
        panic!("{t}")
    };
    assert_eq!(j.joints[4], d("90"));

    let t = doc("4.7.13", Kind::Req, 0);
    let Request::PoseDefdFrame(f) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(f.p6, [d("420"), d("50"), d("495")]);

    let t = doc("4.7.12", Kind::Req, 0);
    let Request::PoseInterpolate(i) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(i.alpha, d("0.5"));
}

#[test]
fn tool_and_user_frames() {
    let t = doc("4.8.5", Kind::Req, 0);
    let Request::SetTCPByName(s) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(s.name, "TCP_1");
    let t = doc("4.8.7", Kind::Ok, 0);
    let Response::ReadTCPByName(r) = ok(&t, ReplyExpect::of(CommandId::ReadTCPByName)) else {
        panic!("{t}")
    };
    assert_eq!(r.tcp[2], d("120"));
}

#[test]
fn force_control() {
    let t = doc("4.9.15", Kind::Req, 0);
    let Request::HRSetControlGoal(g) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(g.force[2], d("10"));
    assert_eq!(g.distance, Some([Decimal::ZERO; 6]));
    let t = doc("4.9.17", Kind::Req, 0);
    let Request::HRSetForceDistanceLimit(l) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((l.allow_distance, l.strength_level), (d("10"), d("2")));
    let t = doc("4.9.1", Kind::Fail, 0);
    let Ok(Reply::Fail(f)) = Reply::parse(&t, ReplyExpect::of(CommandId::SetForceControlState))
    else {
        panic!("{t}")
    };
    assert_eq!(f.code, ErrorCode::NotInForceControl);
}

#[test]
fn motion() {
    let t = vector("chapter4.txt", "4.10.5", Kind::Req, Source::Fixed, 0).text;
    let Request::WayPoint(w) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(
        w.pose,
        [d("420"), d("0"), d("445"), d("180"), d("0"), d("180")]
    );
    assert_eq!((w.tcp_name, w.ucs_name), ("TCP", "Base"));
    assert_eq!((w.velocity, w.acc), (d("50"), d("360")));
    assert_eq!((w.move_type, w.use_joint), (0, 1));
    assert!(CommandId::WayPoint.is_motion());

    // MoveJ's 24-field examples: the move type after the radius is dropped.
    let t = doc("4.10.7", Kind::Req, 1);
    let Request::MoveJ(j) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((j.use_joint, j.cmd_id), (1, "0"));

    let t = doc("4.10.2", Kind::Req, 1);
    let Request::MoveRelL(r) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((r.axis, r.direction, r.distance), (1, 1, d("10")));
    assert_eq!(r.tool_motion, None);

    let t = doc("4.10.11", Kind::Req, 0);
    let Request::MoveE(e) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(e.p3[1], d("10"));
    assert_eq!((e.arc_length, e.cmd_id), (d("360"), "1"));
}

#[test]
fn paths_servo_tracking() {
    let t = doc("4.11.11", Kind::Req, 0);
    let Request::PushMovePaths(p) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((p.track, p.move_type, p.points.len()), ("Path1", 1, 6));
    let points: Vec<_> = p.points.iter().collect();
    assert_eq!(points[5][1], d("50"));

    let t = doc("4.11.9", Kind::Req, 0);
    let Request::InitMovePathL(i) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((i.ucs_name, i.tcp_name), ("Base", "TCP"));
    assert_eq!(i.jerk, d("1000000"));

    let t = doc("4.11.8", Kind::Ok, 0);
    let Response::ReadSoftMotionProgress(s) =
        ok(&t, ReplyExpect::of(CommandId::ReadSoftMotionProgress))
    else {
        panic!("{t}")
    };
    assert_eq!((s.progress, s.index), (d("0.88"), 100));

    let t = doc("4.12.1", Kind::Req, 0);
    let Request::StartServo(s) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((s.servo_time, s.lookahead_time), (d("0.2"), d("0.02")));

    let t = doc("4.13.2", Kind::Req, 0);
    let Request::SetMoveTraceInitParams(m) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((m.k, m.min_limit), (d("-14"), d("65")));
}

#[test]
fn tool_modbus() {
    let t = doc("4.14.2", Kind::Req, 1);
    let Request::WriteHoldingRegisters(w) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!((w.function, w.address), (16, 5000));
    assert_eq!(w.data.as_slice(), [88, 89, 90, 91, 92]);

    let t = doc("4.14.3", Kind::Req, 2);
    let Request::ReadHoldingRegisters(r) = req(&t) else {
        panic!("{t}")
    };
    assert_eq!(r.count, 11);
    assert_eq!(r.expect().count, Some(11));
    let t = doc("4.14.3", Kind::Ok, 2);
    let Response::ReadHoldingRegisters(o) = ok(&t, r.expect()) else {
        panic!("{t}")
    };
    assert_eq!(o.values.last(), Some(&98));
}

#[test]
fn failures() {
    let t = doc("4.6.2", Kind::Fail, 0);
    let Ok(Reply::Fail(f)) = Reply::parse(&t, ReplyExpect::of(CommandId::ReadCmdPos)) else {
        panic!("{t}")
    };
    // The document's copy-paste slip: the name is ReadActPos.
    assert_eq!(
        (f.name, f.command()),
        ("ReadActPos", Some(CommandId::ReadActPos))
    );
    assert_eq!(f.code, ErrorCode::StateRefused);

    let t = vector("variants.txt", "4.2.1", Kind::Fail, Source::Notes, 3).text;
    let Ok(Reply::Fail(f)) = Reply::parse(&t, ReplyExpect::of(CommandId::GrpEnable)) else {
        panic!("{t}")
    };
    assert_eq!(f.detail, "state error, robot moving, try again");

    // The code is read as every integer field is; a code that is not a
    // whole i32 is a typed error naming the field.
    let expect = ReplyExpect::of(CommandId::GrpEnable);
    for (text, code) in [
        ("GrpEnable,Fail, 20018 ,;", 20018),
        ("GrpEnable,Fail,20018.0,;", 20018),
    ] {
        let Ok(Reply::Fail(f)) = Reply::parse(text, expect) else {
            panic!("{text}")
        };
        assert_eq!(f.code, ErrorCode::from(code), "{text}");
    }
    for (text, field) in [
        ("GrpEnable,Fail,20018.5,;", "20018.5"),
        ("GrpEnable,Fail,x1,;", "x1"),
        ("GrpEnable,Fail,9999999999,;", "9999999999"),
    ] {
        assert_eq!(
            Reply::parse(text, expect),
            Err(ParseError::BadErrorCode(Got::Field(field))),
            "{text}"
        );
    }
}

/// A list taking the rest of a message cannot count more than 65535 fields:
/// such a message is refused as a whole, as `RawMessage::parse` refuses it,
/// not read with a wrong count.
#[test]
fn a_rest_of_message_list_over_65535_fields_is_refused() {
    use hans_codec::{grammar::GrammarError, RawMessage};
    for (name, n) in [("RunFunc,f", 70_000), ("HRAppCmd,0,a", 65_536)] {
        let text = format!("{name}{},;", ",1".repeat(n));
        assert_eq!(RawMessage::parse(&text), Err(GrammarError::TooManyFields));
        assert_eq!(
            Request::parse(&text),
            Err(ParseError::Grammar(GrammarError::TooManyFields)),
            "{name} with {n} more fields"
        );
    }
    // At the bound it still reads, with the right count.
    let text = format!("RunFunc,f{},;", ",1".repeat(65_534));
    let Ok(Request::RunFunc(r)) = Request::parse(&text) else {
        panic!("RunFunc with 65535 fields")
    };
    assert_eq!(r.params.len(), 65_534);
    assert_eq!(r.params.iter().count(), 65_534);
}
