//! The methods a frame can render ([`Method`]): their names on the command line, their
//! labels and one-line summaries, and the traits the passes read of them
//! ([`Method::traits`], `tiledlight_gpu::features::MethodTraits`: the gpu crate's passes
//! know a method only by those). A leaf module of this crate: depends only on
//! tiledlight-gpu's [`MethodTraits`], so the settings, the registrations and the renderer
//! can all name a method.

use tiledlight_gpu::features::MethodTraits;

/// How a frame is lit: the one method type of every crate (settings, renderers, reports).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Method {
    /// Depth pre-pass, tiled culling, forward shading of each tile's list.
    #[default]
    ForwardPlus,
    /// G-buffer, then one compute pass that culls each tile and shades it.
    TiledDeferred,
    /// Depth and triangle IDs, tiled culling, then one compute pass that rebuilds each
    /// pixel's surface from its triangle and shades it (the visibility buffer).
    Visibility,
    /// Depth pre-pass, then every light for every pixel (the reference). `cutoff: false`
    /// drops the radius window (plain inverse-square).
    BruteForce {
        /// Keep the windowed falloff with its radius cutoff.
        cutoff: bool,
    },
    /// The truth to measure against: the visibility buffer's surface lit by every light
    /// with no cutoff, each light's share multiplied by a shadow ray through the scene's
    /// BVH (no shadow maps). Seconds a frame, not milliseconds. `cutoff: true` keeps the
    /// windowed falloff (the truth with the tiled methods' cutoff: the lab's error split
    /// measures the cutoff's share of a setting's error with it).
    TracedReference {
        /// Keep the windowed falloff with its radius cutoff.
        cutoff: bool,
    },
    /// Every light shadowed, stochastically (issue 48): the visibility buffer's surface and
    /// its culling; a few candidate lights a pixel drawn from its tile's list and from every
    /// light, one kept in proportion to its unshadowed contribution and shadowed by a ray
    /// through the scene's BVH; the frames of a still view accumulated. No cutoff: it
    /// converges to the truth.
    Stochastic,
}

impl Method {
    /// Every method, in the order reports list them.
    pub const ALL: [Method; 8] = [
        Method::ForwardPlus,
        Method::BruteForce { cutoff: true },
        Method::BruteForce { cutoff: false },
        Method::TiledDeferred,
        Method::Visibility,
        Method::TracedReference { cutoff: false },
        Method::TracedReference { cutoff: true },
        Method::Stochastic,
    ];

    /// The truth the lab measures against: traced, no cutoff.
    pub const TRUTH: Method = Method::TracedReference { cutoff: false };

    /// The traits this method's frame has, which the gpu crate's passes and the pass
    /// settings' table read (`Features::traits`, `Knob::applies`).
    pub const fn traits(self) -> MethodTraits {
        MethodTraits {
            tiled: !matches!(self, Method::BruteForce { .. } | Method::TracedReference { .. }),
            gbuffer: matches!(self, Method::TiledDeferred),
            visibility_buffer: matches!(self, Method::Visibility | Method::TracedReference { .. } | Method::Stochastic),
            traced: matches!(self, Method::TracedReference { .. } | Method::Stochastic),
            stochastic: matches!(self, Method::Stochastic),
            cutoff: !matches!(
                self,
                Method::BruteForce { cutoff: false } | Method::TracedReference { cutoff: false } | Method::Stochastic
            ),
        }
    }

    /// True for the methods with tiles (culling, light grid, heat map).
    pub fn is_tiled(self) -> bool {
        self.traits().tiled
    }

    /// True for the methods whose surface is the visibility buffer's (its raster).
    pub fn uses_visibility_buffer(self) -> bool {
        self.traits().visibility_buffer
    }

    /// True for the methods whose shadows are rays through the scene's BVH: the traced
    /// references and the stochastic method (their scene needs its BVH).
    pub fn is_traced(self) -> bool {
        self.traits().traced
    }

    /// True for the traced references (every light, a ray each: seconds a frame, one frame
    /// enough).
    pub fn is_traced_reference(self) -> bool {
        matches!(self, Method::TracedReference { .. })
    }

    /// True for the references (every light, no tiles): brute force and the traced one.
    pub fn is_reference(self) -> bool {
        !self.is_tiled()
    }

    /// False for the references without the radius window (plain inverse-square): every
    /// other method's lights end at their radius.
    pub fn has_cutoff(self) -> bool {
        self.traits().cutoff
    }

    /// The flag value, for the command line, reports and JSON.
    pub const fn name(self) -> &'static str {
        match self {
            Method::ForwardPlus => "forward-plus",
            Method::BruteForce { cutoff: true } => "brute-force",
            Method::BruteForce { cutoff: false } => "brute-force-no-cutoff",
            Method::TiledDeferred => "deferred",
            Method::Visibility => "visibility",
            Method::TracedReference { cutoff: false } => "traced-reference",
            Method::TracedReference { cutoff: true } => "traced-reference-cutoff",
            Method::Stochastic => "stochastic",
        }
    }

    /// The name people read (the viewer's panel, charts).
    pub fn label(self) -> &'static str {
        match self {
            Method::ForwardPlus => "Forward+",
            Method::BruteForce { cutoff: true } => "Brute force",
            Method::BruteForce { cutoff: false } => "Brute force, no cutoff",
            Method::TiledDeferred => "Tiled Deferred",
            Method::Visibility => "Visibility buffer",
            Method::TracedReference { cutoff: false } => "Traced reference",
            Method::TracedReference { cutoff: true } => "Traced, with the cutoff",
            Method::Stochastic => "Stochastic",
        }
    }

    /// What the method does, in one line (the command line's help).
    pub fn summary(self) -> &'static str {
        match self {
            Method::ForwardPlus => "Depth pre-pass, tiled light culling, forward shading of each tile's list",
            Method::BruteForce { cutoff: true } => {
                "Every light for every pixel, with the radius cutoff (the reference for culling)"
            }
            Method::BruteForce { cutoff: false } => {
                "Every light for every pixel, plain inverse-square (the reference for the cutoff)"
            }
            Method::TiledDeferred => "G-buffer pass, then one compute pass that culls each tile's lights and shades it",
            Method::Visibility => {
                "Depth and triangle IDs, tiled light culling, then one compute pass that rebuilds each pixel's \
                 surface from its triangle and shades it"
            }
            Method::TracedReference { cutoff: false } => {
                "Every light for every pixel, no cutoff, each shadowed by a ray through the scene's BVH (the truth; \
                 seconds a frame)"
            }
            Method::TracedReference { cutoff: true } => {
                "The traced reference with the radius cutoff (the truth less the cutoff's light: the cutoff's share \
                 of the error)"
            }
            Method::Stochastic => {
                "Every light shadowed: a few candidate lights a pixel, one kept by its contribution and shadowed by a \
                 ray, a still view's frames accumulated (converges to the truth)"
            }
        }
    }

    /// The method of flag value `name` ([`Method::name`]).
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
            format!("method {name:?}: use one of {}", names.join(", "))
        })
    }
}

// A row of the run settings' table (tiledlight-setup's `table`): the names, each with its
// summary as its help.
tiledlight_gpu::knob_choice!(Method, Method::ALL, Method::name, Choice, |n| Method::from_name(n)
    .ok()
    .map(Method::summary));

/// `--method` on a command line (feature `clap`): the values are [`Method::name`], their
/// help [`Method::summary`], so a new method needs no second enum.
#[cfg(feature = "clap")]
impl clap::ValueEnum for Method {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.name()).help(self.summary()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Only the two references named "no cutoff" drop the radius window; every name parses
    /// back to its method; the traits say what the names do.
    #[test]
    fn the_cutoff_and_the_names_of_every_method() {
        for m in Method::ALL {
            let no_cutoff = m.name().ends_with("no-cutoff") || m == Method::TRUTH || m == Method::Stochastic;
            assert_eq!(m.has_cutoff(), !no_cutoff, "{m:?}");
            assert_eq!(Method::from_name(m.name()), Ok(m));
        }
        assert!(Method::from_name("nope").unwrap_err().contains("forward-plus"));
        let with = |f: fn(MethodTraits) -> bool| Method::ALL.into_iter().filter(|&m| f(m.traits())).collect::<Vec<_>>();
        assert_eq!(with(|t| t.gbuffer), [Method::TiledDeferred]);
        assert_eq!(with(|t| t.traced), [Method::TRUTH, Method::TracedReference { cutoff: true }, Method::Stochastic]);
        assert_eq!(with(|t| t.stochastic), [Method::Stochastic]);
        assert_eq!(
            with(|t| t.visibility_buffer),
            [Method::Visibility, Method::TRUTH, Method::TracedReference { cutoff: true }, Method::Stochastic]
        );
        let references: Vec<Method> = Method::ALL.into_iter().filter(|m| m.is_reference()).collect();
        assert!(!references.contains(&Method::Stochastic), "the stochastic method is no reference");
        assert_eq!(references.len(), 4);
        assert_eq!(
            with(|t| t.tiled),
            [Method::ForwardPlus, Method::TiledDeferred, Method::Visibility, Method::Stochastic]
        );
    }
}
