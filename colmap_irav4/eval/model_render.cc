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

  // Up: mean of the cameras' up vectors (-y axis of each image in world).
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> centers;
  for (const auto& [image_id, image] : model.images) {
    up += -(image.cam_from_world.rotation.inverse() * Eigen::Vector3d::UnitY());
    centers.push_back(image.ProjectionCenter());
  }
  up = up.norm() > 1e-9 ? up.normalized() : Eigen::Vector3d::UnitY();

  // Scene points for the extent and the horizontal axes (centres if none).
  std::vector<Eigen::Vector3d> cloud;
  cloud.reserve(model.points3D.size() + centers.size());
  for (const auto& [point3D_id, point] : model.points3D)
    cloud.push_back(point.xyz);
  cloud.insert(cloud.end(), centers.begin(), centers.end());
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
  Eigen::Vector3d major = solver.eigenvectors().col(2);
  major -= major.dot(up) * up;
  if (major.norm() < 1e-9) major = up.unitOrthogonal();
  major.normalize();
  const Eigen::Vector3d minor = up.cross(major).normalized();

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
    std::vector<double> us, vs;
    for (const auto& [point3D_id, point] : model.points3D) {
      us.push_back(point.xyz.dot(panel.axis_u));
      vs.push_back(point.xyz.dot(panel.axis_v));
    }
    for (const Eigen::Vector3d& X :
         model.points3D.empty() ? cloud : std::vector<Eigen::Vector3d>()) {
      us.push_back(X.dot(panel.axis_u));
      vs.push_back(X.dot(panel.axis_v));
    }
    double u_lo = Percentile(us, options.extent_percentile);
    double u_hi = Percentile(us, 100 - options.extent_percentile);
    double v_lo = Percentile(vs, options.extent_percentile);
    double v_hi = Percentile(vs, 100 - options.extent_percentile);
    // Every camera stays in view (a few cameras are not outliers).
    for (const Eigen::Vector3d& center : centers) {
      u_lo = std::min(u_lo, center.dot(panel.axis_u));
      u_hi = std::max(u_hi, center.dot(panel.axis_u));
      v_lo = std::min(v_lo, center.dot(panel.axis_v));
      v_hi = std::max(v_hi, center.dot(panel.axis_v));
    }
    panel.u0 = 0.5 * (u_lo + u_hi);
    panel.v0 = 0.5 * (v_lo + v_hi);
    const double span_u = std::max(1e-9, 1.1 * (u_hi - u_lo));
    const double span_v = std::max(1e-9, 1.1 * (v_hi - v_lo));
    panel.scale =
        std::min(panel.area.width / span_u, panel.area.height / span_v);
    cv::rectangle(canvas, panel.area, cv::Scalar(200, 200, 200), 1);
    cv::putText(canvas, titles[p], cv::Point(panel.area.x, margin + margin / 2),
                cv::FONT_HERSHEY_SIMPLEX, 0.0012 * options.height + 0.2,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  const double extent =
      std::max(1e-9, std::max(panels[0].area.width / panels[0].scale,
                              panels[0].area.height / panels[0].scale));

  // Points: own colours, or by height when the model is all grey.
  bool all_grey = true;
  std::vector<double> heights;
  for (const auto& [point3D_id, point] : model.points3D) {
    if (!(point.color(0) == point.color(1) &&
          point.color(1) == point.color(2))) {
      all_grey = false;
    }
    heights.push_back(point.xyz.dot(up));
  }
  const double h_lo = Percentile(heights, 2), h_hi = Percentile(heights, 98);
  cv::Mat lut(1, 256, CV_8UC1);
  for (int k = 0; k < 256; ++k) lut.at<uint8_t>(k) = static_cast<uint8_t>(k);
  cv::Mat colormap;
  cv::applyColorMap(lut, colormap, cv::COLORMAP_VIRIDIS);
  for (int p = 0; p < 2; ++p) {
    cv::Mat panel_view = canvas(panels[p].area);
    for (const auto& [point3D_id, point] : model.points3D) {
      cv::Point pixel = panels[p].ToPixel(point.xyz);
      pixel -= panels[p].area.tl();
      if (!cv::Rect(0, 0, panel_view.cols, panel_view.rows).contains(pixel))
        continue;
      cv::Scalar color;
      if (all_grey) {
        const double t =
            h_hi > h_lo ? (point.xyz.dot(up) - h_lo) / (h_hi - h_lo) : 0.5;
        const int k = std::clamp(static_cast<int>(255 * t), 0, 255);
        const cv::Vec3b c = colormap.at<cv::Vec3b>(0, k);
        color = cv::Scalar(c[0], c[1], c[2]);
      } else {
        color = cv::Scalar(point.color(2), point.color(1), point.color(0));
      }
      if (options.point_radius_px == 0) {
        panel_view.at<cv::Vec3b>(pixel) =
            cv::Vec3b(color[0], color[1], color[2]);
      } else {
        cv::circle(panel_view, pixel, options.point_radius_px, color,
                   cv::FILLED);
      }
    }
  }

  // Camera frusta: apex at the centre, the image corners at a fixed depth.
  const double depth = options.frustum_scale * extent;
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
      cv::Mat view = canvas(panel.area);
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
  return canvas;
}

}  // namespace colmap_irav4
