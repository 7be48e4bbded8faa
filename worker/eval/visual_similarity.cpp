// SSIM after Wang, Bovik, Sheikh and Simoncelli, "Image Quality Assessment:
// From Error Visibility to Structural Similarity", IEEE TIP 13(4), 2004:
//   SSIM(x, y) = (2 mu_x mu_y + C1)(2 sigma_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 + sigma_y^2 + C2))
// with local statistics under an 11x11 Gaussian window (sigma 1.5), C1 =
// (0.01 L)^2, C2 = (0.03 L)^2 (Eq. 13 and Section III-C), averaged over the
// image (Eq. 17).
#include "visual_similarity.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace vpr {
namespace {

std::vector<double> gaussian_kernel(int size, double sigma) {
  std::vector<double> w(static_cast<size_t>(size));
  const int r = size / 2;
  double sum = 0;
  for (int i = 0; i < size; ++i) sum += w[size_t(i)] = std::exp(-double((i - r) * (i - r)) / (2 * sigma * sigma));
  for (double& v : w) v /= sum;
  return w;
}

FloatImage to_float(const GrayImage& g) {
  FloatImage f(g.width, g.height);
  std::copy(g.pixels.begin(), g.pixels.end(), f.pixels.begin());
  return f;
}

// Window centres that see some surface: the union of both coverages, dilated
// by the window's half-width.
Mask surface_centres(const Mask& a, const Mask& b, int half) {
  const int w = a.width, h = a.height;
  Mask rows(w, h, 0), out(w, h, 0);
  for (int y = 0; y < h; ++y) {
    int last = -1 - half;  // last covered x seen so far
    for (int x = 0; x < w + half; ++x) {
      if (x < w && (a.at(x, y) || b.at(x, y))) last = x;
      const int c = x - half;  // centre whose window ends at x
      if (c >= 0 && c < w) {
        bool any = last >= c - half;
        rows.at(c, y) = any;
      }
    }
  }
  for (int x = 0; x < w; ++x) {
    int last = -1 - half;
    for (int y = 0; y < h + half; ++y) {
      if (y < h && rows.at(x, y)) last = y;
      const int c = y - half;
      if (c >= 0 && c < h) out.at(x, c) = last >= c - half;
    }
  }
  return out;
}

Mesh scaled_about_centre(const Mesh& mesh, float factor) {
  const Aabb box = bounding_box(mesh);
  Mesh out = mesh;
  for (size_t v = 0; v < out.vertex_count(); ++v)
    for (int k = 0; k < 3; ++k) {
      const float c = 0.5f * (box.lo[size_t(k)] + box.hi[size_t(k)]);
      out.positions[3 * v + size_t(k)] = c + factor * (mesh.positions[3 * v + size_t(k)] - c);
    }
  return out;
}

}  // namespace

FloatImage gaussian_blur(const FloatImage& image, double sigma) {
  if (!(sigma > 0)) return image;
  const int r = std::max(1, int(std::ceil(3 * sigma)));
  const std::vector<double> k = gaussian_kernel(2 * r + 1, sigma);
  const int w = image.width, h = image.height;
  FloatImage tmp(w, h), out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      for (int i = -r; i <= r; ++i) s += k[size_t(i + r)] * image.at(std::clamp(x + i, 0, w - 1), y);
      tmp.at(x, y) = float(s);
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      for (int i = -r; i <= r; ++i) s += k[size_t(i + r)] * tmp.at(x, std::clamp(y + i, 0, h - 1));
      out.at(x, y) = float(s);
    }
  return out;
}

StatusOr<double> ssim(const FloatImage& a, const FloatImage& b, const SsimOptions& o, const Mask* centres) {
  if (o.window < 1 || o.window % 2 == 0)
    return invalid_argument("SSIM window must be odd and positive, got " + std::to_string(o.window));
  if (!(o.sigma > 0) || !(o.dynamic_range > 0) || !(o.k1 > 0) || !(o.k2 > 0))
    return invalid_argument("SSIM sigma, K1, K2 and L must be positive");
  if (a.width != b.width || a.height != b.height)
    return invalid_argument("SSIM of images of different sizes: " + std::to_string(a.width) + "x" +
                            std::to_string(a.height) + " and " + std::to_string(b.width) + "x" +
                            std::to_string(b.height));
  if (a.width < o.window || a.height < o.window)
    return invalid_argument("SSIM needs images of at least the window's size (" + std::to_string(o.window) +
                            " px), got " + std::to_string(a.width) + "x" + std::to_string(a.height));
  if (centres && (centres->width != a.width || centres->height != a.height))
    return invalid_argument("SSIM centre mask differs in size from the images");

  const int w = a.width, h = a.height, r = o.window / 2;
  const std::vector<double> k = gaussian_kernel(o.window, o.sigma);
  const double c1 = (o.k1 * o.dynamic_range) * (o.k1 * o.dynamic_range);
  const double c2 = (o.k2 * o.dynamic_range) * (o.k2 * o.dynamic_range);
  // Horizontal pass of the five moments, valid columns only.
  const int vw = w - 2 * r;
  std::vector<std::array<double, 5>> rows(size_t(vw) * size_t(h));
  tbb::parallel_for(0, h, [&](int y) {
    for (int x = 0; x < vw; ++x) {
      std::array<double, 5> m{0, 0, 0, 0, 0};
      for (int i = 0; i < o.window; ++i) {
        const double p = a.at(x + i, y), q = b.at(x + i, y), wi = k[size_t(i)];
        m[0] += wi * p;
        m[1] += wi * q;
        m[2] += wi * p * p;
        m[3] += wi * q * q;
        m[4] += wi * p * q;
      }
      rows[size_t(y) * vw + size_t(x)] = m;
    }
  });
  const int vh = h - 2 * r;
  std::vector<double> sum(size_t(vh), 0.0);
  std::vector<size_t> count(size_t(vh), 0);
  tbb::parallel_for(0, vh, [&](int y) {
    for (int x = 0; x < vw; ++x) {
      if (centres && !centres->at(x + r, y + r)) continue;
      std::array<double, 5> m{0, 0, 0, 0, 0};
      for (int i = 0; i < o.window; ++i)
        for (int j = 0; j < 5; ++j) m[size_t(j)] += k[size_t(i)] * rows[size_t(y + i) * vw + size_t(x)][size_t(j)];
      const double mu_a = m[0], mu_b = m[1];
      const double var_a = m[2] - mu_a * mu_a, var_b = m[3] - mu_b * mu_b, cov = m[4] - mu_a * mu_b;
      sum[size_t(y)] +=
          ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a * mu_a + mu_b * mu_b + c1) * (var_a + var_b + c2));
      ++count[size_t(y)];
    }
  });
  double total = 0;
  size_t n = 0;
  for (int y = 0; y < vh; ++y) {  // fixed order: the same value at any thread count
    total += sum[size_t(y)];
    n += count[size_t(y)];
  }
  if (n == 0) return invalid_argument("SSIM centre mask selects no window inside the image");
  return total / double(n);
}

StatusOr<double> ssim(const GrayImage& a, const GrayImage& b, const SsimOptions& options, const Mask* centres) {
  return ssim(to_float(a), to_float(b), options, centres);
}

StatusOr<FloatImage> line_drawing(const Snapshot& snapshot, const ImageSaliencyOptions& features, double sigma) {
  FeatureImages f;
  Status s = cpu::detect_features(snapshot, features, &f, ExecContext{});
  if (!s.ok()) return s;
  FloatImage lines(f.silhouette.width, f.silhouette.height, 0.f);
  for (size_t i = 0; i < lines.pixels.size(); ++i)
    lines.pixels[i] = (f.silhouette.pixels[i] || f.inner.pixels[i]) ? 255.f : 0.f;
  return gaussian_blur(lines, sigma);
}

StatusOr<std::vector<View>> comparison_views(const Mesh& reference, int count, int resolution) {
  if (Status s = validate_mesh(reference); !s.ok()) return invalid_argument("reference: " + s.message());
  ViewOptions vo;
  vo.count = count;
  vo.resolution = resolution;
  vo.user_rotation = alignment_rotation(reference, vo);  // the reference's principal axes, not the scaled copy's
  return make_views(scaled_about_centre(reference, 1.05f), vo);
}

StatusOr<VisualReference> VisualReference::create(const Mesh& reference, Renderer* renderer,
                                                  const VisualSimilarityOptions& options) {
  assert(renderer != nullptr);
  if (Status s = validate_mesh(reference); !s.ok()) return invalid_argument("reference: " + s.message());
  if (!(options.line_blur_sigma >= 0)) return invalid_argument("line blur sigma must be non-negative");
  VisualReference r;
  r.renderer_ = renderer;
  r.options_ = options;
  r.origin_ = reference.origin;
  r.scale_ = reference.scale;
  auto views = comparison_views(reference, options.views, options.resolution);
  if (!views.ok()) return views.status();
  r.views_ = std::move(*views);
  if (Status s = renderer->render(reference, r.views_, &r.snapshots_); !s.ok()) return s;
  for (const Snapshot& snap : r.snapshots_) {
    r.gray_.push_back(to_float(snap.gray));
    if (!options.line_drawings) continue;
    auto lines = line_drawing(snap, options.features, options.line_blur_sigma);
    if (!lines.ok()) return lines.status();
    r.lines_.push_back(std::move(*lines));
  }
  return r;
}

StatusOr<VisualSimilarity> VisualReference::compare(const Mesh& given_candidate) const {
  if (Status s = validate_mesh(given_candidate); !s.ok()) return invalid_argument("candidate: " + s.message());
  // In the reference's frame (the origins may differ: mesh.h).
  Mesh moved;
  const bool same_frame = given_candidate.origin == origin_ && given_candidate.scale == scale_;
  if (!same_frame) moved = rebased(given_candidate, origin_, scale_);
  const Mesh& candidate = same_frame ? given_candidate : moved;
  std::vector<Snapshot> snaps;
  if (Status s = renderer_->render(candidate, views_, &snaps); !s.ok()) return s;
  VisualSimilarity out;
  out.ssim_worst = out.line_worst = std::numeric_limits<double>::infinity();
  for (size_t v = 0; v < views_.size(); ++v) {
    const Mask centres = surface_centres(snapshots_[v].coverage, snaps[v].coverage, options_.ssim.window / 2);
    const Mask* use = options_.surface_windows_only ? &centres : nullptr;
    auto gray = ssim(gray_[v], to_float(snaps[v].gray), options_.ssim, use);
    if (!gray.ok()) return gray.status();
    double line = std::numeric_limits<double>::quiet_NaN();
    if (options_.line_drawings) {
      auto lines = line_drawing(snaps[v], options_.features, options_.line_blur_sigma);
      if (!lines.ok()) return lines.status();
      auto scored = ssim(lines_[v], *lines, options_.ssim, use);
      if (!scored.ok()) return scored.status();
      line = *scored;
    }
    out.per_view.push_back({views_[v].name, *gray, line});
    out.ssim_mean += *gray / double(views_.size());
    out.line_mean += line / double(views_.size());
    if (*gray < out.ssim_worst) {
      out.ssim_worst = *gray;
      out.ssim_worst_view = views_[v].name;
    }
    if (line < out.line_worst) {
      out.line_worst = line;
      out.line_worst_view = views_[v].name;
    }
  }
  if (!options_.line_drawings) out.line_worst = std::numeric_limits<double>::quiet_NaN();
  return out;
}

StatusOr<VisualSimilarity> visual_similarity(const Mesh& reference, const Mesh& candidate,
                                             const VisualSimilarityOptions& options, RendererKind kind) {
  auto renderer = create_renderer(kind);
  if (!renderer.ok()) return renderer.status();
  auto ref = VisualReference::create(reference, renderer->get(), options);
  if (!ref.ok()) return ref.status();
  return ref->compare(candidate);
}

}  // namespace vpr
