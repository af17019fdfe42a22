//! The film window: where a continuous film position lands on the camera's
//! image plane, after conforming the aperture to the image aspect.

use glam::{UVec2, Vec2};

/// An affine map from film positions (pixels, y down) to a rectangle on a
/// camera-space plane (x right, y up): the image plane at z = -1 for a
/// perspective camera (so a point is a direction's tangents), the view
/// rectangle in scene units for an orthographic one.
#[derive(Clone, Copy, Debug)]
pub(super) struct FilmWindow {
    /// Plane position of film (0, 0), the image's top-left corner.
    top_left: Vec2,
    /// Plane offset per pixel; its y is negative because rows run down.
    per_pixel: Vec2,
    /// Plane offset from the top-left to the bottom-right corner (y negative).
    extent: Vec2,
}

impl FilmWindow {
    /// The plane position of `film` (pixels from the top-left corner).
    pub(super) fn at(&self, film: Vec2) -> Vec2 {
        self.top_left + film * self.per_pixel
    }

    /// The top-left corner and the corner-to-corner extent (y negative) of
    /// the rectangle the image covers on the plane: a position with NDC
    /// `ndc` (0 to 1 from the top-left corner, y down) lies at
    /// `top_left + ndc * extent`.
    pub(super) fn corner_and_extent(&self) -> (Vec2, Vec2) {
        (self.top_left, self.extent)
    }

    /// The window of apertures `aperture` centred at `offset` (both in the
    /// same units, USD's tenths of a scene unit), conformed to `raster` and
    /// divided by `units_per_plane_unit` (the focal length for a
    /// perspective camera, 10 for an orthographic one).
    pub(super) fn new(
        aperture: Vec2,
        offset: Vec2,
        raster: Raster,
        units_per_plane_unit: f32,
    ) -> Self {
        let resolution = raster.resolution;
        let size = expand_aperture(aperture, raster) / units_per_plane_unit;
        let centre = offset / units_per_plane_unit;
        let extent = Vec2::new(size.x, -size.y);
        Self {
            top_left: centre + Vec2::new(-0.5, 0.5) * size,
            per_pixel: extent / resolution.as_vec2(),
            extent,
        }
    }
}

/// An image's pixels: how many, and their shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Raster {
    /// Width and height in pixels.
    pub resolution: UVec2,
    /// UsdRender's `pixelAspectRatio`: a pixel's width over its height
    /// (1 for square pixels).
    pub pixel_aspect: f32,
}

impl Raster {
    /// `resolution` square pixels.
    pub fn square(resolution: UVec2) -> Self {
        Self {
            resolution,
            pixel_aspect: 1.0,
        }
    }

    /// The image's aspect: width x pixelAspectRatio / height (UsdRender,
    /// `RenderSettingsBase.aspectRatioConformPolicy`).
    fn image_aspect(self) -> f32 {
        self.resolution.x as f32 * self.pixel_aspect / self.resolution.y as f32
    }
}

/// UsdRender's default `aspectRatioConformPolicy`, "expandAperture": grow the
/// aperture's width or height, about its centre, until its aspect is the
/// image's (`raster`'s width x pixelAspectRatio / height), so the image
/// shows at least the authored aperture. Each pixel then covers
/// pixelAspectRatio times more of the aperture across than down.
fn expand_aperture(aperture: Vec2, raster: Raster) -> Vec2 {
    let image_aspect = raster.image_aspect();
    if image_aspect > aperture.x / aperture.y {
        Vec2::new(aperture.y * image_aspect, aperture.y)
    } else {
        Vec2::new(aperture.x, aperture.x / image_aspect)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expand_aperture_grows_one_side_to_the_image_aspect() {
        let aperture = Vec2::new(36.0, 24.0);
        let square = |x, y| Raster::square(UVec2::new(x, y));
        let wide = expand_aperture(aperture, square(400, 100));
        let tall = expand_aperture(aperture, square(100, 200));
        let same = expand_aperture(aperture, square(300, 200));
        assert!((wide - Vec2::new(96.0, 24.0)).abs().max_element() < 1e-4);
        assert!((tall - Vec2::new(36.0, 72.0)).abs().max_element() < 1e-4);
        assert!((same - aperture).abs().max_element() < 1e-4);
        // 150 pixels twice as wide as tall make the 300:200 image of `same`.
        let anamorphic = Raster {
            resolution: UVec2::new(150, 200),
            pixel_aspect: 2.0,
        };
        let squeezed = expand_aperture(aperture, anamorphic);
        assert!((squeezed - aperture).abs().max_element() < 1e-4);
        // Each of those pixels covers two of the 300x200 square ones.
        let offset = Vec2::new(1.0, -2.0);
        let wide = FilmWindow::new(aperture, offset, anamorphic, 50.0);
        let square = FilmWindow::new(aperture, offset, square(300, 200), 50.0);
        for film in [Vec2::ZERO, Vec2::new(150.0, 200.0), Vec2::new(37.5, 61.0)] {
            let stretched = film * Vec2::new(2.0, 1.0);
            assert!((wide.at(film) - square.at(stretched)).abs().max_element() < 1e-6);
        }
    }

    #[test]
    fn corners_map_to_the_offset_window_with_y_up() {
        let w = FilmWindow::new(
            Vec2::new(20.0, 10.0),
            Vec2::new(4.0, -2.0),
            Raster::square(UVec2::new(200, 100)),
            2.0,
        );
        let close = |a: Vec2, b: Vec2| (a - b).abs().max_element() < 1e-5;
        assert!(close(w.at(Vec2::ZERO), Vec2::new(-3.0, 1.5)));
        assert!(close(w.at(Vec2::new(200.0, 100.0)), Vec2::new(7.0, -3.5)));
        assert!(close(w.at(Vec2::new(100.0, 50.0)), Vec2::new(2.0, -1.0)));
        let (top_left, extent) = w.corner_and_extent();
        assert!(close(top_left, Vec2::new(-3.0, 1.5)));
        assert!(close(top_left + extent, Vec2::new(7.0, -3.5)));
    }
}
