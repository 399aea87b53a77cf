//! Typed values of the V6 commands, through the structs a caller uses
//! (the corpus's `v:` lines check every value through the `Visitor`).
//! Runs with the codec's `v6` feature.
#![cfg(feature = "v6")]

use hans_codec::path::{CartesianPath, PathReply};
use hans_codec::{
    request, response, Command, CommandId, Decimal, ErrorCode, FreeText, Reply, ReplyExpect,
    Request, Response, RobotId, ValueGroups,
};

fn d(s: &str) -> Decimal {
    Decimal::parse(s).expect("decimal literal")
}

fn ok<'a>(text: &'a str, expect: ReplyExpect) -> Response<'a> {
    match Reply::parse(text, expect) {
        Ok(Reply::Ok(r)) => r,
        other => panic!("{text}: {other:?}"),
    }
}

fn encode<'a, C: Command<'a>>(c: &C) -> String {
    let mut buf = [0u8; 4096];
    let n = c.encode(&mut buf).expect("encodes");
    String::from_utf8(buf[..n].to_vec()).expect("ASCII")
}

#[test]
fn error_texts_from_the_controller() {
    let r = request::GetErrorCodeStr {
        code: ErrorCode::StateRefused,
    };
    assert_eq!(encode(&r), "GetErrorCodeStr,20018,;");
    let Response::GetErrorCodeStr(t) = ok(
        "GetErrorCodeStr,OK,Func_1,script has no Func_1,;",
        r.expect(),
    ) else {
        panic!()
    };
    assert_eq!(t.text.as_str(), "Func_1,script has no Func_1");
    assert_eq!(t.text.to_string(), "Func_1,script has no Func_1");
    // Written as read.
    let mut buf = [0u8; 128];
    let n = Response::GetErrorCodeStr(t).encode(&mut buf).unwrap();
    assert_eq!(
        &buf[..n],
        b"GetErrorCodeStr,OK,Func_1,script has no Func_1,;"
    );
    // A text the grammar cannot carry is refused when written.
    let bad = response::GetErrorCodeStr {
        text: FreeText::new("a;b"),
    };
    assert!(Response::from(bad).encode(&mut buf).is_err());
    // The project's own texts, for controllers without GetErrorCodeStr.
    assert_eq!(
        ErrorCode::from(40020).text(),
        Some("Robot not in force control state")
    );
}

#[test]
fn jogging() {
    let start = request::LongJogL {
        rbt_id: RobotId(0),
        axis: 2,
        direction: 0,
        state: 1,
    };
    assert_eq!(encode(&start), "LongJogL,0,2,0,1,;");
    let keep = request::LongMoveEvent { rbt_id: RobotId(0) };
    assert_eq!(encode(&keep), "LongMoveEvent,0,;");
    assert!(CommandId::LongJogL.is_motion() && CommandId::ShortJogJ.is_motion());
    assert!(!CommandId::LongMoveEvent.is_motion());
    let to = request::MoveJTo {
        rbt_id: RobotId(0),
        joints: [d("0"), d("0"), d("90"), d("0"), d("90"), d("0")],
    };
    assert_eq!(encode(&to), "MoveJTo,0,0,0,90,0,90,0,;");
    let bad = request::ShortJogJ {
        rbt_id: RobotId(0),
        axis: 6,
        direction: 1,
    };
    assert_eq!(bad.validate().unwrap_err().param, "axis");
}

#[test]
fn paths() {
    let points = [[d("420"), d("0"), d("445"), d("180"), d("0"), d("180")]; 2];
    let push = request::PushPathPoints {
        rbt_id: RobotId(0),
        path: "aaa",
        points: ValueGroups::new(&points),
    };
    let text = encode(&push);
    assert_eq!(
        text,
        "PushPathPoints,0,aaa,420,0,445,180,0,180,420,0,445,180,0,180,;"
    );
    let again = request::PushPathPoints::parse(&text).unwrap();
    assert_eq!(again.points.len(), 2);
    assert_eq!(again.points.iter().nth(1), Some(points[1]));

    let init = request::InitPath {
        rbt_id: RobotId(0),
        raw_data_type: 1,
        path: "aaa",
        speed_ratio: d("0.3"),
        radius: d("20"),
        cartesian: Some(CartesianPath {
            velocity: d("100"),
            acc: d("200"),
            jerk: d("300"),
            ucs_name: "Base",
            tcp_name: "TCP",
        }),
    };
    assert_eq!(
        encode(&init),
        "InitPath,0,1,aaa,0.3,20,100,200,300,Base,TCP,;"
    );

    // ReadPath: the reply's form follows the request.
    let all = request::ReadPath {
        rbt_id: RobotId(0),
        path: None,
    };
    let Response::ReadPath(r) = ok("ReadPath,OK,drag_3,ccc,;", all.expect()) else {
        panic!()
    };
    let PathReply::Names(names) = r.path else {
        panic!("{r:?}")
    };
    assert_eq!(names.iter().collect::<Vec<_>>(), ["drag_3", "ccc"]);
    let one = request::ReadPath {
        rbt_id: RobotId(0),
        path: Some("aaa"),
    };
    let text = "ReadPath,OK,0,3,0,5,20046,0.500,3.000,1000.000,1250.000,10000000.000,\
                0,0,0,0,0,0,0,0,0,0,0,0,10,1,2,3,4,5,6,;";
    let Response::ReadPath(r) = ok(text, one.expect()) else {
        panic!()
    };
    let PathReply::Info(info) = r.path else {
        panic!("{r:?}")
    };
    assert_eq!((info.state_j, info.state_l), (3, 5));
    assert_eq!(info.error_l, ErrorCode::Unknown(20046));
    assert_eq!(info.raw_points, 10);
    assert_eq!(
        info.first_point,
        Some([d("1"), d("2"), d("3"), d("4"), d("5"), d("6")])
    );
}

#[test]
fn the_v6_forms_of_old_commands() {
    let ao = request::ReadBoxAO {
        channels: [0, 1].into_iter().collect(),
    };
    let Response::ReadBoxAO(r) = ok("ReadBoxAO,OK,1,2.000,2,8.000,;", ao.expect()) else {
        panic!()
    };
    assert_eq!(r.values.as_slice(), [d("2.000"), d("8.000")]);
    assert_eq!(r.modes.as_ref().map(|m| m.as_slice()), Some(&[1, 2][..]));
    let Response::ReadBoxAO(r) = ok("ReadBoxAO,OK,5.5,3.8,;", ao.expect()) else {
        panic!()
    };
    assert_eq!(r.modes, None);

    let p = request::SetPayload {
        rbt_id: RobotId(0),
        mass: d("3"),
        center: [d("10"), d("20"), d("30")],
        update_db: Some(3),
    };
    assert_eq!(encode(&p), "SetPayload,0,3,10,20,30,3,;");
    let p = request::SetPayload {
        update_db: None,
        ..p
    };
    assert_eq!(encode(&p), "SetPayload,0,3,10,20,30,;");

    // MovePathJ is a command of its own with `v6`, no longer MovePath's alias.
    let Request::MovePathJ(m) = Request::parse("MovePathJ,0,drag_1,;").unwrap() else {
        panic!()
    };
    assert_eq!(m.path, "drag_1");
}

#[test]
fn package_version_gives_the_level() {
    let r = request::PackageVersion {};
    let Response::PackageVersion(v) = ok("PackageVersion,OK,6.3.6.20240305,;", r.expect()) else {
        panic!()
    };
    let level = hans_codec::ProtocolLevel::parse(v.version).unwrap();
    assert!(CommandId::InitPath.available_at(level));
    assert!(!CommandId::ReadBrakeStatus.available_at(level));
}
