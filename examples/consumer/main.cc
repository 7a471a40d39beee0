// Calls the IRAv4 rotation averager in-process on a tiny synthetic problem
// and checks the result: 12 cameras with known rotations, every pair within
// 4 positions measured with 1 degree of noise, three pairs replaced by
// outliers. Prints one line and exits 0 when every rotation is recovered
// within 2 degrees (after removing the global gauge), 1 otherwise.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"
#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace {

Eigen::Matrix3d RandomRotation(std::mt19937_64* rng, double max_angle_rad) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, max_angle_rad);
  const Eigen::Vector3d axis =
      Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)).normalized();
  return Eigen::AngleAxisd(uniform(*rng), axis).toRotationMatrix();
}

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c =
      std::clamp(((a.transpose() * b).trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

}  // namespace

int main() {
  constexpr int kNumCameras = 12;
  std::mt19937_64 rng(7);
  std::vector<Eigen::Matrix3d> truth;
  colmap_irav4::RotationGraph graph;
  for (int i = 0; i < kNumCameras; ++i) {
    truth.push_back(RandomRotation(&rng, M_PI));
    graph.AddVertex("image" + std::to_string(i) + ".jpg");
  }
  int num_edges = 0;
  for (int i = 0; i < kNumCameras; ++i) {
    for (int j = i + 1; j < kNumCameras && j <= i + 4; ++j) {
      Eigen::Matrix3d R_ij = truth[j] * truth[i].transpose();
      if (num_edges % 11 == 5) {
        R_ij = RandomRotation(&rng, M_PI);  // outlier
      } else {
        R_ij = RandomRotation(&rng, 1.0 * M_PI / 180.0) * R_ij;  // noise
      }
      graph.AddEdge(i, j, R_ij, 100.0);
      ++num_edges;
    }
  }

  const std::unique_ptr<colmap_irav4::RotationAverager> averager =
      colmap_irav4::CreateRotationAverager(
          "irav4", colmap_irav4::RotationAveragerOptions());
  const colmap_irav4::RotationAveragingResult result =
      averager->Estimate(graph);

  // Remove the gauge: align on camera 0 (R_est = R_true G).
  const Eigen::Matrix3d gauge = truth[0].transpose() * result.rotations[0];
  double max_error_deg = 0.0;
  for (int i = 0; i < kNumCameras; ++i) {
    if (!result.estimated[i]) continue;
    max_error_deg = std::max(max_error_deg,
                             AngleDeg(truth[i] * gauge, result.rotations[i]));
  }
  const bool ok = result.NumEstimated() == kNumCameras && max_error_deg < 2.0;
  std::cout << averager->Name() << ": " << result.NumEstimated() << "/"
            << kNumCameras << " rotations from " << graph.NumEdges()
            << " pairs, max error " << max_error_deg
            << " deg: " << (ok ? "OK" : "FAILED") << std::endl;
  return ok ? 0 : 1;
}
