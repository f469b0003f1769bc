"""lobe's Mitsuba 3 reference tooling: convert lobe scene JSON files into Mitsuba scenes
(written from lobe's documented scene format, independently of lobe's Rust loader), and
custom Mitsuba BSDF plugins for the models of Ngan et al. 2005 that Mitsuba lacks,
written from the papers' formulas (docs/models.md)."""

import mitsuba as mi

VARIANTS = ("llvm_ad_rgb", "scalar_rgb")


def set_variant():
    """The first available of llvm_ad_rgb (needs libLLVM) and scalar_rgb."""
    for v in VARIANTS:
        try:
            mi.set_variant(v)
            return v
        except Exception:  # noqa: BLE001 - Mitsuba raises generic errors for missing LLVM
            continue
    raise RuntimeError("no usable Mitsuba variant among " + ", ".join(VARIANTS))
