//! The committed tiny BPT references (`fixtures/references/*-tiny.exr`) agree with Mitsuba 3's
//! path tracer on the exported scenes (`tools/check_references.py`: image means within 1%, 32²
//! blocks within 3%), and carry their provenance. Needs tools/.venv (tools/setup.sh); fails,
//! never skips, without it.

mod util;

use mixmc::exrio::ExrImage;
use mixmc::study::SCENES;
use serde_json::Value;

// The tiny twins of the study's scenes are each checked against Mitsuba at `SPP`. (The committed
// `cornell-box` and `caustic` references are checked by the script only, docs/references.md:
// tests/methods.rs already compares BPT with Mitsuba on those scenes from its own renders.)
const SPP: &str = "1024";

#[test]
fn tiny_references_match_mitsuba_and_say_how_they_were_made() {
    util::python(); // fail at once without tools/.venv
    let mut failures = Vec::new();
    for scene in SCENES {
        let reference = util::fixture(&format!("references/{scene}-tiny.exr"));
        let header = ExrImage::read(reference.as_ref()).unwrap();
        // The render commands: the file's own, or its inputs' if it is a merge of passes.
        let commands = header
            .text_attr("mixmc.input_commands")
            .or_else(|| header.text_attr("mixmc.command"))
            .unwrap_or_default();
        for command in commands.lines() {
            assert!(
                command.contains("--method bpt") && command.contains(&format!("{scene}-tiny.json")),
                "{reference}: render command `{command}`"
            );
        }
        assert!(!commands.is_empty(), "{reference}: no render command");
        assert!(header.float_attr("mixmc.spp").unwrap_or(0.0) >= 64.0);
        assert!(header.float_attr("mixmc.seconds").unwrap_or(0.0) > 0.0);

        let mut cmd = util::python_tool("check_references.py");
        cmd.arg(util::fixture(&format!("scenes/{scene}-tiny.json")))
            .arg(&reference)
            .args(["--spp", SPP, "--passes", "8", "--json"])
            .arg("--scene-tool")
            .arg(util::SCENE);
        let out = util::cmd_output(&mut cmd);
        let text = util::show(&out);
        println!("{scene}:\n{text}");
        let last = String::from_utf8_lossy(&out.stdout)
            .lines()
            .last()
            .unwrap_or_default()
            .to_string();
        let Ok(json) = serde_json::from_str::<Value>(&last) else {
            failures.push(format!("{scene}: no JSON report ({})\n{text}", out.status));
            continue;
        };
        // Exclusions must leave most of the image judged: at least 3 of the 4 blocks per channel.
        let judged_min = ["R", "G", "B"]
            .iter()
            .map(|c| json["channels"][c]["blocks_judged"].as_u64().unwrap_or(0))
            .min()
            .unwrap_or(0);
        if out.status.code() != Some(0) || json["ok"] != Value::Bool(true) || judged_min < 3 {
            failures.push(format!(
                "{scene}: exit {:?}, {judged_min} of 4 blocks judged\n{text}",
                out.status.code()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
