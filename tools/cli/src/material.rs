//! The material options shared by several commands (`--material`, `--scene` with
//! `--name`, `--ngan` with `--model`): the description they give, the files it reads (for
//! the input/output check) and the built material.

use lobe_materials::Bsdf;
use lobe_materials::registry::{BuildContext, Registry};
use lobe_renderer::Error;
use lobe_renderer::outputs::FilePlan;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where a material comes from (shared by eval, tabulate, fit and figure).
#[derive(clap::Args)]
pub struct MaterialArgs {
    /// Material description: a JSON object, or @FILE holding one.
    #[arg(long, conflicts_with_all = ["scene", "ngan"])]
    material: Option<String>,
    /// Take the material from this scene file (with --name).
    #[arg(long, requires = "name")]
    scene: Option<PathBuf>,
    /// Name of the scene's material (under "materials").
    #[arg(long)]
    name: Option<String>,
    /// A published Ngan et al. fit: the MERL material name (with --model).
    #[arg(long, requires = "model")]
    ngan: Option<String>,
    /// Model of the Ngan fit: ward, ward-duer, blinn-phong, lafortune, cook-torrance,
    /// ashikhmin-shirley, he.
    #[arg(long)]
    model: Option<String>,
}

/// A material description from the command line, not yet built: the JSON, the file it
/// came from (for errors and as an input), its JSON path and the folder its relative
/// paths resolve against.
pub struct MaterialSource {
    desc: Value,
    shown: String,
    file: Option<PathBuf>,
    path: String,
    base: PathBuf,
}

impl MaterialSource {
    pub fn new(args: &MaterialArgs) -> Result<Self, Error> {
        let here = std::env::current_dir().unwrap_or_default();
        let folder = |p: &Path| p.parent().map(Path::to_path_buf).unwrap_or(here.clone());
        if let Some(m) = &args.material {
            if let Some(path) = m.strip_prefix('@') {
                let p = PathBuf::from(path);
                return Ok(Self {
                    desc: lobe_materials::json::read(&p)?,
                    shown: p.display().to_string(),
                    base: folder(&p),
                    file: Some(p),
                    path: "material".into(),
                });
            }
            return Ok(Self {
                desc: lobe_materials::json::parse(m, "--material")?,
                shown: "--material".into(),
                file: None,
                path: "material".into(),
                base: here,
            });
        }
        if let Some(scene) = &args.scene {
            let name = args.name.as_deref().unwrap_or_default();
            return Ok(Self {
                desc: scene_material(scene, name)?,
                shown: scene.display().to_string(),
                base: folder(scene),
                file: Some(scene.clone()),
                path: format!("materials.{name}"),
            });
        }
        if let Some(mat) = &args.ngan {
            return Ok(Self {
                desc: serde_json::json!({"type": "ngan-fit", "material": mat, "model": args.model.clone().unwrap_or_default()}),
                shown: "--ngan".into(),
                file: None,
                path: "material".into(),
                base: here,
            });
        }
        Err(Error::Other("expected a material: --material JSON, --scene FILE --name NAME, or --ngan MATERIAL --model MODEL".into()))
    }

    /// Adds the files the material reads (its description's file and its tables,
    /// reports or distributions) to `plan`.
    pub fn plan_inputs(&self, plan: &mut FilePlan) {
        if let Some(f) = &self.file {
            plan.input(f, "the material's description");
        }
        let registry = Registry::builtin();
        let ctx = BuildContext::new(&self.base, &registry);
        for p in registry.inputs(&self.desc, &ctx) {
            plan.input(p, format!("a file the material of {} reads", self.shown));
        }
    }

    /// A name for the material in figure titles: the stem of the file it reads, the
    /// published fit's material, the scene's material name, or else its type.
    pub fn label(&self) -> String {
        let text = |k: &str| self.desc.get(k).and_then(Value::as_str);
        if let Some(f) = text("file") {
            return lobe_analysis::fitting::stem(Path::new(f));
        }
        if let (Some("ngan-fit"), Some(m)) = (text("type"), text("material")) {
            return m.to_string();
        }
        if let Some(name) = self.path.strip_prefix("materials.") {
            return name.to_string();
        }
        text("type").unwrap_or("material").to_string()
    }

    pub fn build(&self) -> Result<Arc<dyn Bsdf>, Error> {
        let registry = Registry::builtin();
        registry
            .create_with(
                &self.desc,
                &self.path,
                &BuildContext::new(&self.base, &registry),
            )
            .map_err(|e| Error::scene(&self.shown, e.path, e.message))
    }
}

/// The description of the material `name` under a scene file's "materials".
fn scene_material(scene: &Path, name: &str) -> Result<Value, Error> {
    let v = lobe_renderer::scene::read_json(scene)?;
    v.get("materials")
        .and_then(|m| m.get(name))
        .cloned()
        .ok_or_else(|| {
            let names: Vec<String> = v
                .get("materials")
                .and_then(Value::as_object)
                .map(|o| o.keys().cloned().collect())
                .unwrap_or_default();
            Error::scene(
                scene.display().to_string(),
                format!("materials.{name}"),
                format!("no such material; expected one of: {}", names.join(", ")),
            )
        })
}

pub fn load_material(args: &MaterialArgs) -> Result<Arc<dyn Bsdf>, Error> {
    MaterialSource::new(args)?.build()
}
