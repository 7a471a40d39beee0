#include "colmap_irav4/eval/model_render.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

double Percentile(std::vector<double> values, double percent) {
  if (values.empty()) return 0;
  const size_t k = std::min(
      values.size() - 1,
      static_cast<size_t>(percent / 100.0 * (values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

// One panel: world points -> pixels through two axes of the view frame.
struct Panel {
  cv::Rect area;
  Eigen::Vector3d axis_u, axis_v;  // v drawn upwards
  double u0 = 0, v0 = 0, scale = 1;
  cv::Point ToPixel(const Eigen::Vector3d& X) const {
    const double u = X.dot(axis_u) - u0, v = X.dot(axis_v) - v0;
    return cv::Point(
        area.x + static_cast<int>(std::lround(0.5 * area.width + scale * u)),
        area.y + static_cast<int>(std::lround(0.5 * area.height - scale * v)));
  }
};

// Up: mean of the cameras' up vectors (-y axis of each image in world).
Eigen::Vector3d MeanCameraUp(const Reconstruction& model) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const auto& [image_id, image] : model.images) {
    up += -(image.cam_from_world.rotation.inverse() * Eigen::Vector3d::UnitY());
  }
  return up.norm() > 1e-9 ? up.normalized() : Eigen::Vector3d::UnitY();
}

// The horizontal axes (major, minor) of the view frame: the principal axes
// of `cloud` orthogonal to `up`.
void HorizontalAxes(const std::vector<Eigen::Vector3d>& cloud,
                    const Eigen::Vector3d& up, Eigen::Vector3d* major,
                    Eigen::Vector3d* minor) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& X : cloud) mean += X;
  mean /= cloud.size();
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& X : cloud) {
    Eigen::Vector3d h = X - mean;
    h -= h.dot(up) * up;
    scatter += h * h.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  *major = solver.eigenvectors().col(2);
  *major -= major->dot(up) * up;
  if (major->norm() < 1e-9) *major = up.unitOrthogonal();
  major->normalize();
  *minor = up.cross(*major).normalized();
}

// Centres panel's view on the points (percentile extent; `cloud` where the
// model has none) and on every camera, and scales it to the panel's area.
void FitPanel(const Reconstruction& model,
              const std::vector<Eigen::Vector3d>& cloud,
              const std::vector<Eigen::Vector3d>& centers,
              double extent_percentile, Panel* panel) {
  std::vector<double> us, vs;
  for (const auto& [point3D_id, point] : model.points3D) {
    us.push_back(point.xyz.dot(panel->axis_u));
    vs.push_back(point.xyz.dot(panel->axis_v));
  }
  for (const Eigen::Vector3d& X :
       model.points3D.empty() ? cloud : std::vector<Eigen::Vector3d>()) {
    us.push_back(X.dot(panel->axis_u));
    vs.push_back(X.dot(panel->axis_v));
  }
  double u_lo = Percentile(us, extent_percentile);
  double u_hi = Percentile(us, 100 - extent_percentile);
  double v_lo = Percentile(vs, extent_percentile);
  double v_hi = Percentile(vs, 100 - extent_percentile);
  // Every camera stays in view (a few cameras are not outliers).
  for (const Eigen::Vector3d& center : centers) {
    u_lo = std::min(u_lo, center.dot(panel->axis_u));
    u_hi = std::max(u_hi, center.dot(panel->axis_u));
    v_lo = std::min(v_lo, center.dot(panel->axis_v));
    v_hi = std::max(v_hi, center.dot(panel->axis_v));
  }
  panel->u0 = 0.5 * (u_lo + u_hi);
  panel->v0 = 0.5 * (v_lo + v_hi);
  const double span_u = std::max(1e-9, 1.1 * (u_hi - u_lo));
  const double span_v = std::max(1e-9, 1.1 * (v_hi - v_lo));
  panel->scale =
      std::min(panel->area.width / span_u, panel->area.height / span_v);
}

// Point colours: their own, or by height when the model is all grey.
class PointColors {
 public:
  PointColors(const Reconstruction& model, const Eigen::Vector3d& up)
      : up_(up) {
    std::vector<double> heights;
    for (const auto& [point3D_id, point] : model.points3D) {
      if (!(point.color(0) == point.color(1) &&
            point.color(1) == point.color(2))) {
        all_grey_ = false;
      }
      heights.push_back(point.xyz.dot(up));
    }
    h_lo_ = Percentile(heights, 2);
    h_hi_ = Percentile(heights, 98);
    cv::Mat lut(1, 256, CV_8UC1);
    for (int k = 0; k < 256; ++k) lut.at<uint8_t>(k) = static_cast<uint8_t>(k);
    cv::applyColorMap(lut, colormap_, cv::COLORMAP_VIRIDIS);
  }
  cv::Scalar Of(const Point3D& point) const {
    if (!all_grey_) {
      return cv::Scalar(point.color(2), point.color(1), point.color(0));
    }
    const double t =
        h_hi_ > h_lo_ ? (point.xyz.dot(up_) - h_lo_) / (h_hi_ - h_lo_) : 0.5;
    const int k = std::clamp(static_cast<int>(255 * t), 0, 255);
    const cv::Vec3b c = colormap_.at<cv::Vec3b>(0, k);
    return cv::Scalar(c[0], c[1], c[2]);
  }

 private:
  Eigen::Vector3d up_;
  bool all_grey_ = true;
  double h_lo_ = 0, h_hi_ = 0;
  cv::Mat colormap_;
};

void DrawPoints(const Reconstruction& model, const Panel& panel,
                const PointColors& colors, int point_radius_px,
                cv::Mat* canvas) {
  cv::Mat panel_view = (*canvas)(panel.area);
  for (const auto& [point3D_id, point] : model.points3D) {
    cv::Point pixel = panel.ToPixel(point.xyz);
    pixel -= panel.area.tl();
    if (!cv::Rect(0, 0, panel_view.cols, panel_view.rows).contains(pixel))
      continue;
    const cv::Scalar color = colors.Of(point);
    if (point_radius_px == 0) {
      panel_view.at<cv::Vec3b>(pixel) = cv::Vec3b(color[0], color[1], color[2]);
    } else {
      cv::circle(panel_view, pixel, point_radius_px, color, cv::FILLED);
    }
  }
}

// Camera frusta: apex at the centre, the image corners at `depth`.
void DrawFrusta(const Reconstruction& model, const Panel (&panels)[2],
                double depth, cv::Mat* canvas) {
  for (const auto& [image_id, image] : model.images) {
    const auto camera_it = model.cameras.find(image.camera_id);
    double half_w = 0.5, half_h = 0.375;
    if (camera_it != model.cameras.end() && camera_it->second.width > 0) {
      const Camera& camera = camera_it->second;
      const double focal = CameraMeanFocalLength(camera);
      if (focal > 0) {
        half_w = 0.5 * camera.width / focal;
        half_h = 0.5 * camera.height / focal;
      }
    }
    const Rigid3d world_from_cam = image.cam_from_world.Inverse();
    const Eigen::Vector3d center = world_from_cam.translation;
    Eigen::Vector3d corners[4];
    const double signs[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int k = 0; k < 4; ++k) {
      corners[k] =
          world_from_cam * (depth * Eigen::Vector3d(signs[k][0] * half_w,
                                                    signs[k][1] * half_h, 1));
    }
    for (const Panel& panel : panels) {
      cv::Mat view = (*canvas)(panel.area);
      const cv::Point offset = panel.area.tl();
      const cv::Point apex = panel.ToPixel(center) - offset;
      const cv::Scalar red(30, 30, 220);
      for (int k = 0; k < 4; ++k) {
        const cv::Point a = panel.ToPixel(corners[k]) - offset;
        const cv::Point b = panel.ToPixel(corners[(k + 1) % 4]) - offset;
        cv::line(view, apex, a, red, 1, cv::LINE_AA);
        cv::line(view, a, b, red, 1, cv::LINE_AA);
      }
    }
  }
}

}  // namespace

void ModelRenderOptions::Check() const {
  if (width < 64 || height < 64 || width > 20000 || height > 20000) {
    throw InputError("--width/--height", "must be in [64, 20000] px");
  }
  if (point_radius_px < 0 || point_radius_px > 20) {
    throw InputError("--point_radius", "must be in [0, 20] px");
  }
  if (!(frustum_scale > 0 && frustum_scale < 1)) {
    throw InputError("--frustum_scale", "must be in (0, 1)");
  }
  if (!(extent_percentile >= 0 && extent_percentile < 50)) {
    throw InputError("--extent_percentile", "must be in [0, 50)");
  }
}

cv::Mat RenderModel(const Reconstruction& model,
                    const ModelRenderOptions& options) {
  options.Check();
  if (model.images.empty()) throw InputError("model has no images");

  const Eigen::Vector3d up = MeanCameraUp(model);
  std::vector<Eigen::Vector3d> centers;
  for (const auto& [image_id, image] : model.images) {
    centers.push_back(image.ProjectionCenter());
  }
  // Scene points for the extent and the horizontal axes (centres if none).
  std::vector<Eigen::Vector3d> cloud;
  cloud.reserve(model.points3D.size() + centers.size());
  for (const auto& [point3D_id, point] : model.points3D)
    cloud.push_back(point.xyz);
  cloud.insert(cloud.end(), centers.begin(), centers.end());
  Eigen::Vector3d major, minor;
  HorizontalAxes(cloud, up, &major, &minor);

  cv::Mat canvas(options.height, options.width, CV_8UC3,
                 cv::Scalar(255, 255, 255));
  const int panel_width = options.width / 2;
  const int margin = std::max(10, options.height / 25);
  Panel panels[2];
  panels[0].axis_u = major;  // top view: looking down
  panels[0].axis_v = minor;
  panels[1].axis_u = major;  // side view: looking along the minor axis
  panels[1].axis_v = up;
  const char* titles[2] = {"top view", "side view"};
  for (int p = 0; p < 2; ++p) {
    Panel& panel = panels[p];
    panel.area =
        cv::Rect(p * panel_width + margin, margin + margin,
                 panel_width - 2 * margin, options.height - 3 * margin);
    FitPanel(model, cloud, centers, options.extent_percentile, &panel);
    cv::rectangle(canvas, panel.area, cv::Scalar(200, 200, 200), 1);
    cv::putText(canvas, titles[p], cv::Point(panel.area.x, margin + margin / 2),
                cv::FONT_HERSHEY_SIMPLEX, 0.0012 * options.height + 0.2,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  const double extent =
      std::max(1e-9, std::max(panels[0].area.width / panels[0].scale,
                              panels[0].area.height / panels[0].scale));

  const PointColors colors(model, up);
  for (const Panel& panel : panels) {
    DrawPoints(model, panel, colors, options.point_radius_px, &canvas);
  }
  DrawFrusta(model, panels, options.frustum_scale * extent, &canvas);
  return canvas;
}

}  // namespace colmap_irav4
