//! The command line as clap parses it, for every subcommand: the defaults, each flag family, the
//! value parsers (resolutions, split ratios, hold-outs, DSI thresholds, bone weights, variation
//! bounds), and the combinations refused before anything runs (missing inputs, conflicting
//! flags, bad values). Parsed field values are checked, not only that parsing succeeds.

use std::f64::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};

use autoact::bags::render::EmbedVideo;
use autoact::cli::{Cli, Command};
use autoact::cmd::EXIT_USAGE;
use autoact::cmd::convert::{DsiSourceArg, SmoothArg};
use autoact::cmd::import::Axes;
use autoact::cmd::plan::PlanFormat;
use autoact::dsi::plan::Threshold;
use autoact::dsi::variants::VariationBounds;
use autoact::dsi::{self, DsiOptions};
use autoact::export::ExportFormat;
use autoact::formats::import::InputFormat;
use autoact::mcap_io::{Compression, Rosbag2Version};
use autoact::record::run::{DurabilityArg, ReliabilityArg};
use autoact::skeleton::convert::RootMotion;
use autoact::skeleton::ground::GroundMode;
use autoact::skeleton::lengths::LengthMode;
use autoact::skeleton::rig::{DofSet, Rig};
use autoact::trim::split::Key;
use clap::error::ErrorKind;
use clap::{CommandFactory, Parser, ValueEnum};

/// `autoact ARGS…`, parsed; fails the test with clap's message if refused.
fn parse(args: &[&str]) -> Cli {
    let argv = std::iter::once("autoact").chain(args.iter().copied());
    Cli::try_parse_from(argv).unwrap_or_else(|e| panic!("autoact {}: {e}", args.join(" ")))
}

/// The error `autoact ARGS…` is refused with; fails the test if it parses.
fn refused(args: &[&str]) -> clap::Error {
    let argv = std::iter::once("autoact").chain(args.iter().copied());
    match Cli::try_parse_from(argv) {
        Ok(cli) => panic!("autoact {} parsed: {:?}", args.join(" "), cli.command),
        Err(e) => e,
    }
}

/// How `autoact ARGS…` is refused, after checking that it is a usage error (exit code 2) whose
/// message names `needle` (the flag or value at fault).
fn refused_kind(args: &[&str], needle: &str) -> ErrorKind {
    let e = refused(args);
    assert_eq!(e.exit_code(), i32::from(EXIT_USAGE), "{e}");
    let text = e.to_string();
    assert!(text.contains(needle), "`{needle}` not in: {text}");
    e.kind()
}

/// A value of a value enum by its command-line name; the type comes from the field it is
/// compared with (so `Format`, wherever it lives, needs no import here).
fn value<T: ValueEnum>(name: &str) -> T {
    T::from_str(name, false).unwrap_or_else(|e| panic!("`{name}`: {e}"))
}

/// The arguments of the subcommand `variant` in `autoact ARGS…`.
macro_rules! args_of {
    ($variant:ident, $args:expr) => {
        match parse($args).command {
            Command::$variant(args) => args,
            other => panic!("expected {}, parsed {other:?}", stringify!($variant)),
        }
    };
}

fn path(p: &str) -> PathBuf {
    PathBuf::from(p)
}

#[test]
fn every_subcommand_has_a_parsing_test_here() {
    let tested = [
        "convert", "export", "generate", "import", "info", "layouts", "merge", "plan", "record",
        "recover", "render", "rig", "trim",
    ];
    let mut names: Vec<String> = Cli::command()
        .get_subcommands()
        .map(|c| c.get_name().to_owned())
        .filter(|name| name != "help")
        .collect();
    names.sort();
    assert_eq!(
        names, tested,
        "a new subcommand needs its test in this file"
    );
}

#[test]
fn global_flags_count_verbosity_and_quiet_refuses_verbose() {
    let cli = parse(&["rig"]);
    assert_eq!((cli.global.verbose, cli.global.quiet), (0, false));
    let cli = parse(&["-vv", "rig"]);
    assert_eq!((cli.global.verbose, cli.global.quiet), (2, false));
    // Global: after the subcommand too.
    let cli = parse(&["info", "a.mcap", "-v", "--verbose"]);
    assert_eq!(cli.global.verbose, 2);
    let cli = parse(&["info", "a.mcap", "-q"]);
    assert_eq!((cli.global.verbose, cli.global.quiet), (0, true));
    assert_eq!(
        refused_kind(&["-q", "-v", "rig"], "--quiet"),
        ErrorKind::ArgumentConflict
    );
    assert_eq!(
        refused_kind(&["rig", "--frobnicate"], "--frobnicate"),
        ErrorKind::UnknownArgument
    );
    assert_eq!(
        refused(&[]).kind(),
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    );
}

#[test]
fn rig_lists_one_thing_at_a_time() {
    let args = args_of!(Rig, &["rig"]);
    assert_eq!(args.format, value("table"));
    assert_eq!(args.layout, None);
    assert!(!args.landmarks && !args.recipes);
    let args = args_of!(Rig, &["rig", "--format", "json", "--layout", "h36m-17"]);
    assert_eq!(args.format, value("json"));
    assert_eq!(args.layout.as_deref(), Some("h36m-17"));
    let args = args_of!(Rig, &["rig", "--landmarks"]);
    assert!(args.landmarks && !args.recipes);
    let args = args_of!(Rig, &["rig", "--recipes", "--layout", "my.toml"]);
    assert!(args.recipes && !args.landmarks);
    assert_eq!(args.layout.as_deref(), Some("my.toml"));
    assert_eq!(
        refused_kind(&["rig", "--landmarks", "--recipes"], "--recipes"),
        ErrorKind::ArgumentConflict
    );
    assert_eq!(
        refused_kind(&["rig", "--format", "yaml"], "yaml"),
        ErrorKind::InvalidValue
    );
}

#[test]
fn layouts_lists_all_or_shows_one() {
    let args = args_of!(Layouts, &["layouts"]);
    assert_eq!(args.layout, None);
    assert_eq!(args.format, value("table"));
    let args = args_of!(Layouts, &["layouts", "coco-17", "--format", "json"]);
    assert_eq!(args.layout.as_deref(), Some("coco-17"));
    assert_eq!(args.format, value("json"));
    assert_eq!(
        refused_kind(&["layouts", "a", "b"], "b"),
        ErrorKind::UnknownArgument
    );
}

#[test]
fn import_defaults_formats_labels_and_output() {
    let args = args_of!(Import, &["import", "walk.bvh", "-o", "walk.pose.mcap"]);
    assert_eq!(args.input, Path::new("walk.bvh"));
    assert_eq!(args.format, InputFormat::Auto);
    assert_eq!(args.layout, None);
    assert_eq!(args.bvh_map, None);
    assert_eq!(args.fps, None);
    assert_eq!(args.axes, None);
    assert_eq!(args.metres_per_unit, None);
    assert_eq!((args.category, args.action), (None, None));
    assert_eq!(args.output.output, Path::new("walk.pose.mcap"));
    assert_eq!(args.output.compression, Compression::Zstd);
    assert!(!args.output.rosbag2 && !args.output.write_expected_json);

    let args = args_of!(
        Import,
        &[
            "import",
            "people.json",
            "--format",
            "mmpose-json",
            "--layout",
            "coco-17",
            "--fps",
            "25",
            "--axes",
            "z-up",
            "--metres-per-unit",
            "0.001",
            "--category",
            "daily",
            "--action",
            "wave",
            "--output",
            "out",
            "--compression",
            "lz4",
            "--rosbag2",
        ]
    );
    assert_eq!(args.format, InputFormat::MmposeJson);
    assert_eq!(args.layout.as_deref(), Some("coco-17"));
    assert_eq!(args.fps, Some(25.0));
    assert_eq!(args.axes, Some(Axes::ZUp));
    assert_eq!(args.metres_per_unit, Some(0.001));
    assert_eq!(args.category.as_deref(), Some("daily"));
    assert_eq!(args.action.as_deref(), Some("wave"));
    assert_eq!(args.output.output, Path::new("out"));
    assert_eq!(args.output.compression, Compression::Lz4);
    assert!(args.output.rosbag2);

    let args = args_of!(
        Import,
        &[
            "import",
            "mine.bvh",
            "--bvh-map",
            "maps/mine.toml",
            "-o",
            "o"
        ]
    );
    assert_eq!(args.bvh_map.as_deref(), Some(Path::new("maps/mine.toml")));

    for (name, format) in [
        ("bvh", InputFormat::Bvh),
        ("ntu", InputFormat::Ntu),
        ("h36m-expmap", InputFormat::H36mExpmap),
        ("zed-mat", InputFormat::ZedMat),
    ] {
        let args = args_of!(Import, &["import", "f", "--format", name, "-o", "o"]);
        assert_eq!(args.format, format, "{name}");
    }
    let args = args_of!(Import, &["import", "f", "-o", "o", "--axes", "y-up"]);
    assert_eq!(args.axes, Some(Axes::YUp));
    assert_eq!(
        (args.ground, args.lengths),
        (GroundMode::Auto, LengthMode::Measured)
    );
    let args = args_of!(
        Import,
        &[
            "import",
            "f",
            "-o",
            "o",
            "--ground",
            "off",
            "--lengths",
            "fixed"
        ]
    );
    assert_eq!(
        (args.ground, args.lengths),
        (GroundMode::Off, LengthMode::Fixed)
    );
    let args = args_of!(Import, &["import", "f", "-o", "o", "--ground", "on"]);
    assert_eq!(args.ground, GroundMode::On);
    assert_eq!(
        refused_kind(&["import", "f", "-o", "o", "--ground", "yes"], "yes"),
        ErrorKind::InvalidValue
    );

    assert_eq!(
        refused_kind(&["import", "-o", "o.mcap"], "<INPUT>"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["import", "walk.bvh"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["import", "f", "-o", "o", "--format", "c3d"], "c3d"),
        ErrorKind::InvalidValue
    );
    assert_eq!(
        refused_kind(&["import", "f", "-o", "o", "--fps", "fast"], "--fps"),
        ErrorKind::ValueValidation
    );
}

#[test]
fn convert_defaults_and_bag_flags() {
    let args = args_of!(Convert, &["convert", "in.mcap", "-o", "out.mcap"]);
    assert_eq!(args.input, Some(path("in.mcap")));
    assert_eq!((args.spec, args.topic, args.layout), (None, None, None));
    assert_eq!(args.fps, 30.0);
    assert_eq!(args.root_motion, RootMotion::Full);
    assert_eq!(args.dof, DofSet::Full);
    assert_eq!(args.min_confidence, 0.3);
    assert_eq!(args.max_gap, None);
    assert_eq!(args.output.output, Path::new("out.mcap"));
    assert_eq!(args.output.compression, Compression::Zstd);
    assert!(!args.output.rosbag2 && !args.output.write_expected_json && !args.output.force);
    let dsi = args.dsi;
    assert!(!dsi.dsi);
    assert_eq!(dsi.dsi_threshold, None);
    assert_eq!(dsi.eta, None);
    assert!(dsi.dsi_weights.is_empty());
    assert_eq!((dsi.speed, dsi.delta), (None, None));
    assert_eq!((dsi.smooth, dsi.smooth_bass), (None, None));
    assert_eq!(dsi.dsi_source, DsiSourceArg::Auto);
    assert_eq!(dsi.variants, 0);
    assert_eq!(dsi.variation_deg, VariationBounds::default());
    assert_eq!(dsi.seed, 0);

    let args = args_of!(
        Convert,
        &[
            "convert",
            "in",
            "-o",
            "out",
            "--topic",
            "/markers",
            "--layout",
            "h36m-17",
            "--fps",
            "60",
            "--root-motion",
            "in-place",
            "--min-confidence",
            "0.5",
            "--max-gap",
            "0.25",
            "--rosbag2",
            "--compression",
            "none",
            "--write-expected-json",
            "--force",
        ]
    );
    assert!(args.output.force);
    assert_eq!(args.topic.as_deref(), Some("/markers"));
    assert_eq!(args.layout.as_deref(), Some("h36m-17"));
    assert_eq!(args.fps, 60.0);
    assert_eq!(args.root_motion, RootMotion::InPlace);
    assert_eq!(args.min_confidence, 0.5);
    assert_eq!(args.max_gap, Some(0.25));
    assert!(args.output.rosbag2 && args.output.write_expected_json);
    assert_eq!(args.output.compression, Compression::None);
    let args = args_of!(
        Convert,
        &["convert", "in", "-o", "o", "--root-motion", "pinned"]
    );
    assert_eq!(args.root_motion, RootMotion::Pinned);
    let args = args_of!(Convert, &["convert", "in", "-o", "o", "--dof", "paper"]);
    assert_eq!(args.dof, DofSet::Paper);
    assert_eq!(
        refused_kind(&["convert", "i", "-o", "o", "--dof", "wide"], "wide"),
        ErrorKind::InvalidValue
    );
}

#[test]
fn convert_dsi_smoothing_and_variants() {
    let args = args_of!(
        Convert,
        &[
            "convert",
            "in",
            "-o",
            "out",
            "--dsi",
            "--eta",
            "12.5",
            "--dsi-weight",
            "LeftArm=3",
            "--dsi-weight",
            "Spine=1.5",
            "--speed",
            "0.5",
            "--smooth",
            "0.1,0.25,0.5",
            "--smooth-bass",
            "2",
            "--variants",
            "3",
            "--variation-deg",
            "4",
            "--seed",
            "7",
        ]
    );
    let dsi = args.dsi;
    assert!(dsi.dsi);
    assert_eq!(dsi.eta, Some(12.5));
    assert_eq!(dsi.dsi_weights, ["LeftArm=3", "Spine=1.5"]);
    assert_eq!((dsi.speed, dsi.delta), (Some(0.5), None));
    assert_eq!(dsi.smooth, Some(SmoothArg::Spans([0.1, 0.25, 0.5])));
    assert_eq!(dsi.smooth_bass, Some(2.0));
    assert_eq!(dsi.variants, 3);
    let four = VariationBounds {
        three_d_deg: 4.0,
        two_d_deg: 4.0,
        hinge_deg: 4.0,
        root_deg: 0.0,
    };
    assert_eq!(dsi.variation_deg, four);
    assert_eq!(dsi.seed, 7);
    let dsi = args_of!(Convert, &["convert", "i", "-o", "o", "--delta", "0.8"]).dsi;
    assert_eq!((dsi.speed, dsi.delta), (None, Some(0.8)));
    for (text, smooth) in [("on", SmoothArg::On), ("off", SmoothArg::Off)] {
        let dsi = args_of!(Convert, &["convert", "i", "-o", "o", "--smooth", text]).dsi;
        assert_eq!(dsi.smooth, Some(smooth), "{text}");
    }
    let dsi = args_of!(
        Convert,
        &[
            "convert",
            "i",
            "-o",
            "o",
            "--variation-deg",
            "hinge=10,root=2"
        ]
    )
    .dsi;
    let bounds = VariationBounds {
        hinge_deg: 10.0,
        root_deg: 2.0,
        ..VariationBounds::default()
    };
    assert_eq!(dsi.variation_deg, bounds);
}

#[test]
fn convert_dsi_thresholds_in_each_unit_and_bad_dsi_values() {
    for (text, threshold) in [
        ("3x", Threshold::TimesMedian(3.0)),
        ("0.05rad", Threshold::RadPerFrame(0.05)),
        ("1.5rad/s", Threshold::RadPerSecond(1.5)),
        ("90deg/s", Threshold::RadPerSecond(FRAC_PI_2)),
        ("off", Threshold::Off),
    ] {
        let dsi = args_of!(
            Convert,
            &["convert", "i", "-o", "o", "--dsi-threshold", text]
        )
        .dsi;
        assert_eq!(dsi.dsi_threshold, Some(threshold), "{text}");
    }
    for (text, kind) in [
        ("auto", None),
        ("mocap", Some(dsi::SourceKind::Mocap)),
        ("estimator", Some(dsi::SourceKind::Estimator)),
    ] {
        let dsi = args_of!(Convert, &["convert", "i", "-o", "o", "--dsi-source", text]).dsi;
        assert_eq!(dsi.dsi_source.kind(), kind, "{text}");
    }
    // Bad values as `--flag=VALUE`, so that those starting with `-` reach the value parser.
    for bad in ["3", "-1x", "0rad", "fast", "1.5deg"] {
        assert_eq!(
            refused_kind(
                &["convert", "i", "-o", "o", &format!("--dsi-threshold={bad}")],
                bad
            ),
            ErrorKind::ValueValidation,
            "{bad}"
        );
    }
    for bad in ["0.1,0.2", "soft"] {
        assert_eq!(
            refused_kind(
                &["convert", "i", "-o", "o", &format!("--smooth={bad}")],
                bad
            ),
            ErrorKind::ValueValidation,
            "{bad}"
        );
    }
    for bad in ["91", "3d=-1", "elbow=3", "3d"] {
        assert_eq!(
            refused_kind(
                &["convert", "i", "-o", "o", &format!("--variation-deg={bad}")],
                "--variation-deg"
            ),
            ErrorKind::ValueValidation,
            "{bad}"
        );
    }
    assert_eq!(
        refused_kind(
            &["convert", "i", "-o", "o", "--speed", "2", "--delta", "1"],
            "--delta"
        ),
        ErrorKind::ArgumentConflict
    );
}

#[test]
fn convert_dsi_weights_are_bone_weight_pairs_in_order() {
    let rig = Rig::standard();
    let dsi = args_of!(
        Convert,
        &[
            "convert",
            "i",
            "-o",
            "o",
            "--dsi-weight",
            "l_calf=2.5",
            "--dsi-weight",
            " r_thigh = 0 ",
            "--dsi-weight",
            "l_calf=4",
        ]
    )
    .dsi;
    assert_eq!(dsi.dsi_weights, ["l_calf=2.5", " r_thigh = 0 ", "l_calf=4"]);
    let mut weights = DsiOptions::new(&rig).weights;
    let before = weights.clone();
    dsi::apply_weight_overrides(&rig, &mut weights, &dsi.dsi_weights)
        .unwrap_or_else(|e| panic!("{e}"));
    let bone = |name: &str| rig.bone_index(name).unwrap_or_else(|| panic!("no {name}"));
    // The last pair for a bone wins; the other bones keep their defaults.
    assert_eq!(weights[bone("l_calf")], 4.0);
    assert_eq!(weights[bone("r_thigh")], 0.0);
    for (b, (now, was)) in weights.iter().zip(&before).enumerate() {
        if b != bone("l_calf") && b != bone("r_thigh") {
            assert_eq!(now, was, "bone {b}");
        }
    }
    for bad in [
        "knee=2",
        "l_calf",
        "l_calf=-1",
        "l_calf=heavy",
        "l_calf=inf",
    ] {
        let mut weights = before.clone();
        let result = dsi::apply_weight_overrides(&rig, &mut weights, &[bad.to_owned()]);
        assert!(result.is_err(), "{bad}");
    }
}

#[test]
fn convert_a_spec_instead_of_a_bag_and_what_is_refused() {
    // A dataset spec instead of a bag: `-o` is then the sessions' folder.
    let args = args_of!(
        Convert,
        &["convert", "--spec", "dataset.toml", "-o", "capture"]
    );
    assert_eq!(args.input, None);
    assert_eq!(args.spec, Some(path("dataset.toml")));
    assert_eq!(args.output.output, Path::new("capture"));
    let args = args_of!(
        Convert,
        &[
            "convert",
            "--spec",
            "d.toml",
            "-o",
            "c",
            "--dsi",
            "--variants",
            "2"
        ]
    );
    assert!(args.dsi.dsi);
    assert_eq!(args.dsi.variants, 2);
    for extra in [
        &["in.mcap"][..],
        &["--topic", "/skeleton"],
        &["--layout", "coco-17"],
        &["--rosbag2"],
        &["--dof", "paper"],
    ] {
        let mut argv = vec!["convert", "--spec", "d.toml", "-o", "c"];
        argv.extend_from_slice(extra);
        assert_eq!(
            refused_kind(&argv, "--spec"),
            ErrorKind::ArgumentConflict,
            "{extra:?}"
        );
    }
    assert_eq!(
        refused_kind(&["convert", "-o", "out.mcap"], "<INPUT>"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["convert", "in.mcap"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["convert", "--spec", "d.toml"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["convert", "i", "-o", "o", "--root-motion", "fly"], "fly"),
        ErrorKind::InvalidValue
    );
}

#[test]
fn plan_prints_a_summary_json_or_csv() {
    let args = args_of!(Plan, &["plan", "dataset.toml"]);
    assert_eq!(args.spec, Path::new("dataset.toml"));
    assert_eq!(args.format, PlanFormat::Summary);
    assert_eq!(args.output, None);
    let args = args_of!(
        Plan,
        &["plan", "d.toml", "--format", "json", "-o", "plan.json"]
    );
    assert_eq!(args.format, PlanFormat::Json);
    assert_eq!(args.output, Some(path("plan.json")));
    assert!(!args.force);
    let args = args_of!(Plan, &["plan", "d.toml", "-o", "p.json", "--force"]);
    assert!(args.force);
    assert_eq!(
        refused_kind(&["plan", "d.toml", "--force"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
    let args = args_of!(Plan, &["plan", "d.toml", "--format", "csv"]);
    assert_eq!(args.format, PlanFormat::Csv);
    assert_eq!(
        refused_kind(&["plan"], "<SPEC>"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["plan", "d.toml", "--format", "table"], "table"),
        ErrorKind::InvalidValue
    );
}

#[test]
fn recover_needs_input_and_output() {
    let args = args_of!(Recover, &["recover", "cut.mcap", "-o", "whole.mcap"]);
    assert_eq!(args.input, Path::new("cut.mcap"));
    assert_eq!(args.output, Path::new("whole.mcap"));
    assert!(!args.force);
    assert_eq!(args.compression, Compression::Zstd);
    let args = args_of!(
        Recover,
        &[
            "recover",
            "cut.mcap",
            "--output",
            "w",
            "--force",
            "--compression",
            "lz4"
        ]
    );
    assert!(args.force);
    assert_eq!(args.compression, Compression::Lz4);
    assert_eq!(
        refused_kind(&["recover", "cut.mcap"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["recover", "-o", "w.mcap"], "<INPUT>"),
        ErrorKind::MissingRequiredArgument
    );
}

#[test]
fn every_command_writing_a_rosbag2_directory_takes_its_format_version() {
    // Default 9; 5 for Humble; nothing else.
    let convert = |extra: &[&str]| {
        let mut argv = vec!["convert", "in.mcap", "-o", "out", "--rosbag2"];
        argv.extend_from_slice(extra);
        args_of!(Convert, &argv).output
    };
    assert_eq!(
        convert(&[]).rosbag2_format.rosbag2_version,
        Rosbag2Version::V9
    );
    let humble = convert(&["--rosbag2-version", "5"]);
    assert_eq!(humble.rosbag2_format.rosbag2_version, Rosbag2Version::V5);
    assert_eq!(humble.options().rosbag2, Some(Rosbag2Version::V5));
    assert_eq!(
        args_of!(Convert, &["convert", "in.mcap", "-o", "out.mcap"])
            .output
            .options()
            .rosbag2,
        None
    );
    let import = args_of!(
        Import,
        &[
            "import",
            "a.bvh",
            "-o",
            "o",
            "--rosbag2",
            "--rosbag2-version",
            "5"
        ]
    );
    assert_eq!(import.output.options().rosbag2, Some(Rosbag2Version::V5));
    let record = args_of!(Record, &["record", "-o", "live", "--rosbag2-version", "5"]);
    assert_eq!(record.rosbag2.rosbag2_version, Rosbag2Version::V5);
    let record = args_of!(Record, &["record", "-o", "live"]);
    assert_eq!(record.rosbag2.rosbag2_version, Rosbag2Version::V9);
    let recover = args_of!(
        Recover,
        &["recover", "run", "-o", "fixed", "--rosbag2-version", "5"]
    );
    assert_eq!(recover.rosbag2.rosbag2_version, Rosbag2Version::V5);
    assert_eq!(
        refused_kind(
            &[
                "convert",
                "in.mcap",
                "-o",
                "o",
                "--rosbag2",
                "--rosbag2-version",
                "8"
            ],
            "8"
        ),
        ErrorKind::InvalidValue
    );
    // A format version without a directory to write is a mistake, not silently ignored.
    assert_eq!(
        refused_kind(
            &[
                "convert",
                "in.mcap",
                "-o",
                "o.mcap",
                "--rosbag2-version",
                "5"
            ],
            "--rosbag2"
        ),
        ErrorKind::MissingRequiredArgument
    );
}

#[test]
fn record_topics_qos_splits_and_limits() {
    let args = args_of!(Record, &["record", "-o", "live.mcap"]);
    assert!(args.topics.is_empty());
    assert!(!args.all && !args.force);
    assert_eq!((args.include, args.exclude), (None, None));
    assert_eq!(args.domain_id, None);
    assert_eq!(args.reliability, ReliabilityArg::Reliable);
    assert_eq!(args.durability, DurabilityArg::Volatile);
    assert_eq!(args.depth, None);
    assert_eq!(args.output, Path::new("live.mcap"));
    assert_eq!(args.compression, Compression::Zstd);
    assert_eq!((args.split_size, args.split_duration), (None, None));
    assert_eq!((args.max_duration, args.max_messages), (None, None));
    assert_eq!(args.flush_interval, 1.0);

    let args = args_of!(
        Record,
        &[
            "record",
            "/skeleton",
            "/camera/image",
            "-o",
            "live",
            "--all",
            "--include",
            "^/people/",
            "--exclude",
            "image$",
            "--domain-id",
            "42",
            "--reliability",
            "best-effort",
            "--durability",
            "transient-local",
            "--depth",
            "10",
            "--force",
            "--compression",
            "lz4",
            "--split-size",
            "512",
            "--split-duration",
            "60",
            "--max-duration",
            "5.5",
            "--max-messages",
            "1000",
            "--flush-interval",
            "0.25",
        ]
    );
    assert_eq!(args.topics, ["/skeleton", "/camera/image"]);
    assert!(args.all && args.force);
    assert_eq!(args.include.as_deref(), Some("^/people/"));
    assert_eq!(args.exclude.as_deref(), Some("image$"));
    assert_eq!(args.domain_id, Some(42));
    assert_eq!(args.reliability, ReliabilityArg::BestEffort);
    assert_eq!(args.durability, DurabilityArg::TransientLocal);
    assert_eq!(args.depth, Some(10));
    assert_eq!(args.compression, Compression::Lz4);
    assert_eq!(args.split_size, Some(512));
    assert_eq!(args.split_duration, Some(60.0));
    assert_eq!(args.max_duration, Some(5.5));
    assert_eq!(args.max_messages, Some(1000));
    assert_eq!(args.flush_interval, 0.25);

    assert_eq!(
        refused_kind(&["record", "/skeleton"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["record", "-o", "o", "--domain-id", "70000"], "70000"),
        ErrorKind::ValueValidation
    );
    assert_eq!(
        refused_kind(&["record", "-o", "o", "--reliability", "lossy"], "lossy"),
        ErrorKind::InvalidValue
    );
    assert_eq!(
        refused_kind(&["record", "-o", "o", "--depth", "0"], "0"),
        ErrorKind::ValueValidation
    );
}

#[test]
fn render_resolution_encoder_and_outputs() {
    let args = args_of!(Render, &["render", "session.capture.mcap"]);
    assert_eq!(args.capture, Path::new("session.capture.mcap"));
    assert_eq!(args.output, None);
    assert_eq!(args.engine.resolution, None);
    assert_eq!(args.engine.fps, None);
    assert_eq!(args.engine.crf, autoact::video::DEFAULT_CRF);
    assert_eq!(args.engine.preset, autoact::video::DEFAULT_PRESET);
    assert_eq!(args.engine.gop, None);
    assert_eq!(
        (args.frames_out, args.preview, args.render_bag),
        (None, None, None)
    );
    assert_eq!((args.limit, args.engine.threads), (None, None));
    assert!(args.embed_video.is_none() && !args.force && !args.engine.download_ffmpeg);

    let args = args_of!(
        Render,
        &[
            "render",
            "c.mcap",
            "-o",
            "c.mp4",
            "--resolution",
            "640x360",
            "--fps",
            "25",
            "--crf",
            "0",
            "--preset",
            "veryslow",
            "--gop",
            "60",
            "--frames-out",
            "frames",
            "--preview",
            "sheet.png",
            "--render-bag",
            "r.mcap",
            "--embed-video",
            "--limit",
            "10",
            "--threads",
            "2",
            "--force",
            "--download-ffmpeg",
        ]
    );
    assert_eq!(args.output, Some(path("c.mp4")));
    assert_eq!(args.engine.resolution, Some((640, 360)));
    assert_eq!(args.engine.fps, Some(25.0));
    assert_eq!(args.engine.crf, 0);
    assert_eq!(args.engine.preset, "veryslow");
    assert_eq!(args.engine.gop, Some(60));
    assert_eq!(args.frames_out, Some(path("frames")));
    assert_eq!(args.preview, Some(path("sheet.png")));
    assert_eq!(args.render_bag, Some(path("r.mcap")));
    assert_eq!((args.limit, args.engine.threads), (Some(10), Some(2)));
    assert_eq!(args.embed_video, Some(EmbedVideo::Foxglove));
    assert!(args.force && args.engine.download_ffmpeg);
    // A viewer's name only after `=`: `--embed-video c.mcap` keeps the capture positional.
    for (flag, embed) in [
        ("--embed-video=foxglove", EmbedVideo::Foxglove),
        ("--embed-video=rerun", EmbedVideo::Rerun),
        ("--embed-video=both", EmbedVideo::Both),
    ] {
        let args = args_of!(Render, &["render", flag, "c.mcap"]);
        assert_eq!(args.embed_video, Some(embed), "{flag}");
    }
    let args = args_of!(Render, &["render", "--embed-video", "c.mcap"]);
    assert_eq!(
        (args.embed_video, args.capture),
        (Some(EmbedVideo::Foxglove), path("c.mcap"))
    );
    assert_eq!(
        refused_kind(&["render", "c", "--embed-video=vlc"], "--embed-video"),
        ErrorKind::InvalidValue
    );
    let args = args_of!(
        Render,
        &["render", "c", "--resolution", "1280X720", "--crf", "51"]
    );
    assert_eq!(args.engine.resolution, Some((1280, 720)));
    assert_eq!(args.engine.crf, 51);

    for bad in ["640", "640x", "x360", "wide", "640x-360", "640.5x360"] {
        assert_eq!(
            refused_kind(
                &["render", "c", &format!("--resolution={bad}")],
                "--resolution"
            ),
            ErrorKind::ValueValidation,
            "{bad}"
        );
    }
    assert_eq!(
        refused_kind(&["render", "c", "--crf", "52"], "--crf"),
        ErrorKind::ValueValidation
    );
    assert_eq!(
        refused_kind(&["render"], "<CAPTURE>"),
        ErrorKind::MissingRequiredArgument
    );
}

#[test]
fn trim_splits_hold_outs_and_encoding() {
    let args = args_of!(Trim, &["trim", "c.capture.mcap", "c.mp4", "-o", "ds"]);
    assert_eq!(args.capture, Path::new("c.capture.mcap"));
    assert_eq!(args.video, Path::new("c.mp4"));
    assert_eq!(args.output, Path::new("ds"));
    assert_eq!((args.video_start, args.video_fps), (None, None));
    assert_eq!(args.render_bag, None);
    assert_eq!(args.split.split_by, Key::Animation);
    assert_eq!(args.split.split_ratios, [0.7, 0.15, 0.15]);
    assert_eq!(args.split.seed, None);
    assert!(args.split.hold_out.is_empty());
    assert!(!args.cut.reencode && !args.cut.rawframes && !args.download_ffmpeg);
    assert_eq!(args.preset, "veryfast");
    assert_eq!(args.crf, 18);

    let args = args_of!(
        Trim,
        &[
            "trim",
            "c",
            "v.mp4",
            "-o",
            "ds",
            "--video-start",
            "-1.5",
            "--video-fps",
            "29.97",
            "--render-bag",
            "v.render.mcap",
            "--split-by",
            "clip",
            "--split-ratios",
            "0.8, 0.1, 0.1",
            "--seed",
            "9",
            "--hold-out",
            "weather=RAIN",
            "--hold-out",
            "time=23:00",
            "--hold-out",
            "Location=street=2",
            "--reencode",
            "--preset",
            "medium",
            "--crf",
            "23",
            "--rawframes",
            "--download-ffmpeg",
        ]
    );
    assert_eq!(args.video_start, Some(-1.5));
    assert_eq!(args.video_fps, Some(29.97));
    assert_eq!(args.render_bag, Some(path("v.render.mcap")));
    assert_eq!(args.split.split_by, Key::Clip);
    assert_eq!(args.split.split_ratios, [0.8, 0.1, 0.1]);
    assert_eq!(args.split.seed, Some(9));
    assert_eq!(
        args.split.hold_out,
        [
            (Key::Weather, "RAIN".to_owned()),
            (Key::Time, "23:00".to_owned()),
            (Key::Location, "street=2".to_owned()),
        ]
    );
    assert!(args.cut.reencode && args.cut.rawframes && args.download_ffmpeg);
    assert_eq!(args.preset, "medium");
    assert_eq!(args.crf, 23);
    // Fractions need not sum to 1; a zero split is allowed.
    let args = args_of!(
        Trim,
        &["trim", "c", "v", "-o", "d", "--split-ratios", "2,1,0"]
    );
    assert_eq!(args.split.split_ratios, [2.0, 1.0, 0.0]);
    let args = args_of!(
        Trim,
        &["trim", "c", "v", "-o", "d", "--hold-out", "character=a1b2"]
    );
    assert_eq!(args.split.hold_out, [(Key::Character, "a1b2".to_owned())]);
}

#[test]
fn trim_refuses_bad_splits_hold_outs_and_missing_paths() {
    for bad in [
        "0.5,0.5",
        "0.7,0.15,0.1,0.05",
        "a,b,c",
        "-0.1,0.6,0.5",
        "0,0,0",
        "inf,1,1",
    ] {
        assert_eq!(
            refused_kind(
                &[
                    "trim",
                    "c",
                    "v",
                    "-o",
                    "d",
                    &format!("--split-ratios={bad}")
                ],
                "--split-ratios"
            ),
            ErrorKind::ValueValidation,
            "{bad}"
        );
    }
    for bad in ["weather", "planet=mars"] {
        assert_eq!(
            refused_kind(
                &["trim", "c", "v", "-o", "d", &format!("--hold-out={bad}")],
                "--hold-out"
            ),
            ErrorKind::ValueValidation,
            "{bad}"
        );
    }
    assert_eq!(
        refused_kind(&["trim", "c", "v", "-o", "d", "--split-by", "mood"], "mood"),
        ErrorKind::InvalidValue
    );
    assert_eq!(
        refused_kind(&["trim", "c", "v", "-o", "d", "--crf", "99"], "--crf"),
        ErrorKind::ValueValidation
    );
    assert_eq!(
        refused_kind(&["trim", "c", "-o", "d"], "<VIDEO>"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["trim", "c", "v"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
}

#[test]
fn info_takes_a_file_and_a_format() {
    let args = args_of!(Info, &["info", "a.mcap"]);
    assert_eq!(args.input, Path::new("a.mcap"));
    assert_eq!(args.format, value("table"));
    let args = args_of!(Info, &["info", "a.mcap", "--format", "json"]);
    assert_eq!(args.format, value("json"));
    assert_eq!(
        refused_kind(&["info"], "<INPUT>"),
        ErrorKind::MissingRequiredArgument
    );
}

#[test]
fn export_formats_selection_listing_and_the_onim_template() {
    let args = args_of!(
        Export,
        &[
            "export",
            "walk.anim.mcap",
            "--format",
            "bvh",
            "-o",
            "walk.bvh"
        ]
    );
    assert_eq!(args.input, Some(path("walk.anim.mcap")));
    assert_eq!(args.format, Some(ExportFormat::Bvh));
    assert_eq!(args.output, Some(path("walk.bvh")));
    assert_eq!((args.animation, args.variant, args.fps), (None, None, None));
    assert_eq!(args.onim_template, None);
    assert!(!args.force && !args.list && !args.print_onim_template && !args.write_expected_json);

    let args = args_of!(
        Export,
        &[
            "export",
            "b.mcap",
            "--format",
            "onim",
            "--output",
            "anims",
            "--animation",
            "2",
            "--variant",
            "1",
            "--force",
            "--fps",
            "60",
            "--onim-template",
            "ped.toml",
            "--write-expected-json",
        ]
    );
    assert_eq!(args.format, Some(ExportFormat::Onim));
    assert_eq!(args.output, Some(path("anims")));
    assert_eq!((args.animation, args.variant), (Some(2), Some(1)));
    assert_eq!(args.fps, Some(60.0));
    assert_eq!(args.onim_template, Some(path("ped.toml")));
    assert!(args.force && args.write_expected_json);
    for (name, format) in [("gltf", ExportFormat::Gltf), ("glb", ExportFormat::Glb)] {
        let args = args_of!(Export, &["export", "b", "--format", name, "-o", "o"]);
        assert_eq!(args.format, Some(format), "{name}");
    }

    // Listing needs only the bag; printing the template needs nothing.
    let args = args_of!(Export, &["export", "b.mcap", "--list"]);
    assert!(args.list);
    assert_eq!((args.format, args.output), (None, None));
    let args = args_of!(Export, &["export", "--print-onim-template"]);
    assert!(args.print_onim_template);
    assert_eq!((args.input, args.format, args.output), (None, None, None));

    assert_eq!(
        refused_kind(&["export", "b.mcap", "-o", "o"], "--format"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["export", "b.mcap", "--format", "bvh"], "--output"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["export", "--format", "bvh", "-o", "o"], "ANIMATION_BAG"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["export", "--list"], "ANIMATION_BAG"),
        ErrorKind::MissingRequiredArgument
    );
    assert_eq!(
        refused_kind(&["export", "b", "--list", "--format", "bvh"], "--list"),
        ErrorKind::ArgumentConflict
    );
    assert_eq!(
        refused_kind(&["export", "b", "--list", "-o", "o"], "--list"),
        ErrorKind::ArgumentConflict
    );
    assert_eq!(
        refused_kind(&["export", "b", "--format", "fbx", "-o", "o"], "fbx"),
        ErrorKind::InvalidValue
    );
    assert_eq!(
        refused_kind(
            &[
                "export",
                "b",
                "--format",
                "bvh",
                "-o",
                "o",
                "--animation",
                "two"
            ],
            "two"
        ),
        ErrorKind::ValueValidation
    );
}

#[test]
fn generate_takes_render_and_trim_options_and_a_shard() {
    let args = args_of!(Generate, &["generate", "d.toml", "-o", "out"]);
    assert_eq!((args.spec, args.output), (path("d.toml"), path("out")));
    assert_eq!(args.shard, None);
    assert_eq!(args.engine.resolution, None);
    assert_eq!(args.engine.crf, autoact::video::DEFAULT_CRF);
    assert_eq!(args.split.split_by, Key::Animation);
    assert!(!args.cut.reencode && !args.cut.rawframes);
    assert!(!args.previews && !args.keep_intermediates && args.abort_after.is_none());
    let args = args_of!(
        Generate,
        &[
            "generate",
            "d.toml",
            "-o",
            "out",
            "--shard",
            "2/4",
            "--resolution",
            "320x240",
            "--threads",
            "2",
            "--split-by",
            "scene",
            "--seed",
            "5",
            "--hold-out",
            "weather=RAIN",
            "--rawframes",
            "--previews",
            "--keep-intermediates",
        ]
    );
    let shard = args.shard.unwrap();
    assert_eq!((shard.index, shard.count), (2, 4));
    assert_eq!(args.engine.resolution, Some((320, 240)));
    assert_eq!(args.engine.threads, Some(2));
    assert_eq!(args.split.split_by, Key::Scene);
    assert_eq!(args.split.seed, Some(5));
    assert_eq!(args.split.hold_out, [(Key::Weather, "RAIN".to_owned())]);
    assert!(args.cut.rawframes && args.previews && args.keep_intermediates);
    for bad in ["4/4", "1", "x/2", "0/0"] {
        refused_kind(
            &["generate", "d.toml", "-o", "o", "--shard", bad],
            "--shard",
        );
    }
    refused_kind(&["generate", "d.toml"], "--output");
}

#[test]
fn merge_takes_parts_and_an_output() {
    let args = args_of!(Merge, &["merge", "p/0", "p/1", "-o", "out", "--force"]);
    assert_eq!(args.parts, [path("p/0"), path("p/1")]);
    assert_eq!(args.output, path("out"));
    assert!(args.force);
    assert_eq!(
        refused_kind(&["merge", "-o", "out"], "<PART>"),
        ErrorKind::MissingRequiredArgument
    );
}
