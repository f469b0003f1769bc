//! The models lobe ships with, gathered into a [`Registry`]: the analytic models of Ngan et
//! al. 2005 (section 3.1; declared in their own files, listed in [`crate::analytic::MODELS`]),
//! Lambert, the measured-data materials, the published fits, fit reports and the
//! microfacet-distribution generator. This module is the only one that knows them all; the
//! registry itself knows none.

use crate::registry::Registry;

impl Registry {
    /// Every model lobe ships with. Call it once where a scene or a fit is set up and pass
    /// the registry on (materials that build materials use the one in their
    /// [`crate::registry::BuildContext`]).
    pub fn builtin() -> Self {
        let mut r = Self::new();
        r.register(crate::analytic::lambert::SCHEMA, |p, _| {
            crate::analytic::lambert::build(p)
        });
        for m in crate::analytic::MODELS {
            r.register_model(m);
        }
        crate::ngan_fit::register(&mut r);
        crate::measured::material::register(&mut r);
        crate::fit::register(&mut r);
        crate::microfacet_gen::register(&mut r);
        r
    }
}

impl Default for Registry {
    fn default() -> Self {
        Self::builtin()
    }
}
