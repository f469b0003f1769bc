//! `lobe models`: the material models and their parameters (Markdown, as in
//! docs/models.md), or only their names.

use lobe_renderer::Error;

pub fn cmd_models(names: bool) -> Result<(), Error> {
    let reg = lobe_materials::registry::Registry::builtin();
    if names {
        for n in reg.names() {
            println!("{n}");
        }
    } else {
        print!("{}", reg.reference_markdown());
    }
    Ok(())
}
