// Visual similarity of a remeshed model to its reference: SSIM (Wang, Bovik,
// Sheikh and Simoncelli 2004) between renderings of the two from the same
// cameras and light, and between their line drawings (silhouette and inner
// features, as the pipeline's image saliency finds them).
#pragma once

#include <string>
#include <vector>

#include "core/image.h"
#include "saliency/image_saliency.h"
#include "core/mesh.h"
#include "render/snapshot.h"
#include "core/status.h"
#include "render/views.h"

namespace vpr {

struct SsimOptions {
  int window = 11;             // Gaussian window, window x window pixels (odd)
  double sigma = 1.5;          // its standard deviation, pixels
  double k1 = 0.01;            // C1 = (k1 L)^2
  double k2 = 0.03;            // C2 = (k2 L)^2
  double dynamic_range = 255;  // L
};

// Mean SSIM of two images of equal size: the SSIM map over every window that
// lies wholly inside the image (MATLAB's filter2 'valid', as in Wang et al.'s
// reference code), averaged over the window centres where `centres` is nonzero
// (all of them when centres is null; it must be the images' size).
// INVALID_ARGUMENT for different sizes, an image smaller than the window, an
// even or non-positive window, or a mask that selects no valid centre.
StatusOr<double> ssim(const FloatImage& a, const FloatImage& b, const SsimOptions& options = {},
                      const Mask* centres = nullptr);
StatusOr<double> ssim(const GrayImage& a, const GrayImage& b, const SsimOptions& options = {},
                      const Mask* centres = nullptr);

// The image convolved with a normalised Gaussian (3 sigma each side, borders
// clamped). sigma <= 0 returns the image unchanged.
FloatImage gaussian_blur(const FloatImage& image, double sigma);

struct VisualSimilarityOptions {
  int views = 14;        // 6 (axes) or 14 (axes + 8 diagonals), see make_views
  int resolution = 512;  // square images
  SsimOptions ssim;
  // Line drawings are binary; blurring them first makes a one-pixel shift of a
  // line cost a little, not everything.
  double line_blur_sigma = 2.0;
  ImageSaliencyOptions features;  // the pipeline's feature detection, same defaults
  // SSIM averaged over windows that see some surface of either mesh. The
  // background is black in both renderings, and its windows (half or more of
  // each image) would pull every score towards 1.
  bool surface_windows_only = true;
  // Also score the blurred line drawings (line_ssim). Each view's drawing
  // runs the feature detection and a blur, more than half of a comparison's
  // time; a caller that reads only the shaded SSIM (the visual target's
  // search) turns it off, and the line scores are NaN.
  bool line_drawings = true;
};

struct ViewSimilarity {
  std::string view;      // "+x", ..., "-x-y-z"
  double ssim = 0;       // shaded renderings
  double line_ssim = 0;  // blurred line drawings (silhouette | inner features)
};

struct VisualSimilarity {
  double ssim_mean = 0, ssim_worst = 0;
  std::string ssim_worst_view;
  double line_mean = 0, line_worst = 0;
  std::string line_worst_view;
  std::vector<ViewSimilarity> per_view;
};

// The reference rendered once, to compare several candidates against. The
// cameras are the pipeline's (make_views: PCA-aligned, orthographic), framed
// on the reference scaled by 1.05 about its bounding-box centre, so that a
// candidate bulging slightly past the reference is not clipped; the candidate
// is drawn by the same cameras and light.
class VisualReference {
 public:
  // renderer: borrowed, must outlive this object. Errors: make_views' and the
  // renderer's; INVALID_ARGUMENT for a bad option or a mesh failing validate_mesh.
  static StatusOr<VisualReference> create(const Mesh& reference, Renderer* renderer,
                                          const VisualSimilarityOptions& options = {});

  StatusOr<VisualSimilarity> compare(const Mesh& candidate) const;

  const std::vector<View>& views() const { return views_; }
  const std::vector<Snapshot>& snapshots() const { return snapshots_; }

 private:
  Renderer* renderer_ = nullptr;
  VisualSimilarityOptions options_;
  std::vector<View> views_;
  std::vector<Snapshot> snapshots_;
  std::vector<FloatImage> gray_, lines_;
  std::array<double, 3> origin_{0, 0, 0};  // the reference's frame (mesh.h); candidates are rebased to it
  double scale_ = 1;
};

// The cameras VisualReference uses: make_views of the reference scaled by 1.05
// about its bounding-box centre, aligned to the reference's principal axes.
StatusOr<std::vector<View>> comparison_views(const Mesh& reference, int count, int resolution);

// Line drawing of a snapshot: 255 on silhouette and inner-feature pixels, 0
// elsewhere, blurred by sigma.
StatusOr<FloatImage> line_drawing(const Snapshot& snapshot, const ImageSaliencyOptions& features, double sigma);

// One call: VisualReference::create(reference, a new renderer of kind).compare(candidate).
StatusOr<VisualSimilarity> visual_similarity(const Mesh& reference, const Mesh& candidate,
                                             const VisualSimilarityOptions& options = {},
                                             RendererKind kind = RendererKind::kAuto);

}  // namespace vpr
