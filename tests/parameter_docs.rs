//! docs/interfaces.md's table of parameters is generated from the library's table
//! (`balloon::params::PARAMETERS`); this test fails when it is stale. To regenerate it:
//!
//! ```sh
//! BALLOONSEG_BLESS=1 cargo test --test parameter_docs
//! ```

use std::path::Path;

use balloonseg::balloon::params::{Parameter, PARAMETERS};

const BEGIN: &str = "<!-- parameters: generated from PARAMETERS (src/balloon/params.rs) by \
                     `BALLOONSEG_BLESS=1 cargo test --test parameter_docs` -->";
const END: &str = "<!-- end of parameters -->";

fn camel(name: &str) -> String {
    name.split('_')
        .map(|part| {
            let mut chars = part.chars();
            chars.next().map_or(String::new(), |first| {
                first.to_uppercase().chain(chars).collect()
            })
        })
        .collect()
}

fn default(p: &Parameter) -> String {
    match p.unset {
        Some(unset) => format!("unset: {unset}"),
        None => p.default_value().to_string(),
    }
}

fn table() -> String {
    let mut rows = vec![
        BEGIN.to_string(),
        "| C field, Python keyword | CLI flag | VTK | default | values | meaning |".to_string(),
        "|---|---|---|---|---|---|".to_string(),
    ];
    for p in PARAMETERS {
        rows.push(format!(
            "| `{}` | `--{}` | `Set{}` | {} | {} | {} |",
            p.name,
            p.flag,
            camel(p.name),
            default(p),
            p.range_text(),
            p.doc
        ));
    }
    rows.push(END.to_string());
    rows.join("\n")
}

#[test]
fn the_interfaces_doc_lists_every_parameter() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/interfaces.md");
    let doc = std::fs::read_to_string(&path).expect("docs/interfaces.md");
    let (Some(start), Some(end)) = (doc.find(BEGIN), doc.find(END)) else {
        panic!("docs/interfaces.md has no generated table of parameters between {BEGIN} and {END}");
    };
    let current = &doc[start..end + END.len()];
    let wanted = table();
    if current == wanted {
        return;
    }
    if std::env::var_os("BALLOONSEG_BLESS").is_some_and(|v| v == "1") {
        let updated = format!("{}{}{}", &doc[..start], wanted, &doc[end + END.len()..]);
        std::fs::write(&path, updated).expect("writing docs/interfaces.md");
        return;
    }
    panic!(
        "docs/interfaces.md's table of parameters is stale; regenerate it with \
         `BALLOONSEG_BLESS=1 cargo test --test parameter_docs`:\n{wanted}"
    );
}
