//! docs/artifacts.md tabulates the artifact types from their one declaration
//! (`objectsplat_core::artifact::TYPES`); this fails when the page and the code drift.
//! `OBJECTSPLAT_UPDATE_DOCS=1 cargo test -p objectsplat-core --test
//! artifact_docs_match_the_declarations` rewrites the table from the code.

use objectsplat_core::artifact::markdown_table;
use std::path::PathBuf;

const TABLE_HEADER: &str = "| type | folder contents |\n";

#[test]
fn the_types_table_in_docs_is_the_declared_one() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/artifacts.md");
    let page = std::fs::read_to_string(&path).unwrap();
    let start = page
        .find(TABLE_HEADER)
        .expect("docs/artifacts.md has the types table");
    let end = page[start..]
        .find("\n\n")
        .map_or(page.len(), |n| start + n + 1);
    let expected = markdown_table();
    if std::env::var_os("OBJECTSPLAT_UPDATE_DOCS").is_some() {
        let updated = format!("{}{}{}", &page[..start], expected, &page[end..]);
        std::fs::write(&path, updated).unwrap();
        return;
    }
    assert_eq!(
        &page[start..end],
        expected,
        "docs/artifacts.md's types table differs from objectsplat_core::artifact::TYPES; \
         rerun this test with OBJECTSPLAT_UPDATE_DOCS=1 to rewrite the table"
    );
}
