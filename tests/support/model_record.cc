#include "tests/support/model_record.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "base/pose.h"

namespace glomap {
namespace testing {
namespace {

struct RecordedImage {
  Eigen::Vector4d qvec;
  Eigen::Vector3d tvec;
};

struct Record {
  size_t num_points3D = 0;
  size_t num_observations = 0;
  std::map<colmap::camera_t, std::vector<double>> camera_params;
  std::map<std::string, RecordedImage> images;
};

size_t NumObservations(const colmap::Reconstruction& model) {
  size_t num_observations = 0;
  for (const auto& [point_id, point] : model.Points3D()) {
    num_observations += point.Track().Length();
  }
  return num_observations;
}

bool ReadRecord(const std::string& path, Record* record) {
  std::ifstream file(path);
  if (!file) return false;
  std::string line;
  while (std::getline(file, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::string kind;
    in >> kind;
    if (kind == "points3D") {
      std::string word;
      in >> record->num_points3D >> word >> record->num_observations;
    } else if (kind == "camera") {
      colmap::camera_t camera_id;
      in >> camera_id;
      std::vector<double>& params = record->camera_params[camera_id];
      double value;
      while (in >> value) params.push_back(value);
      if (!in.eof()) return false;
      in.clear();
    } else if (kind == "image") {
      std::string name;
      RecordedImage image;
      in >> name;
      for (int k = 0; k < 4; ++k) in >> image.qvec(k);
      for (int k = 0; k < 3; ++k) in >> image.tvec(k);
      record->images[name] = image;
    } else {
      return false;
    }
    if (in.fail()) return false;
  }
  return true;
}

double RelativeDifference(double value, double recorded) {
  return std::abs(value - recorded) / std::max(1.0, std::abs(recorded));
}

}  // namespace

Status WriteModelRecord(const colmap::Reconstruction& model,
                        const std::string& title, const std::string& path) {
  std::ofstream file(path);
  file << std::setprecision(17);
  file << "# " << title << "\n";
  file << "points3D " << model.NumPoints3D() << " observations "
       << NumObservations(model) << "\n";
  std::map<colmap::camera_t, const colmap::Camera*> cameras;
  for (const auto& [camera_id, camera] : model.Cameras()) {
    cameras[camera_id] = &camera;
  }
  for (const auto& [camera_id, camera] : cameras) {
    file << "camera " << camera_id;
    for (const double param : camera->Params()) file << " " << param;
    file << "\n";
  }
  std::map<std::string, const colmap::Image*> images;
  for (const colmap::image_t image_id : model.RegImageIds()) {
    images[model.Image(image_id).Name()] = &model.Image(image_id);
  }
  for (const auto& [name, image] : images) {
    file << "image " << name;
    for (int k = 0; k < 4; ++k) file << " " << image->Qvec()(k);
    for (int k = 0; k < 3; ++k) file << " " << image->Tvec()(k);
    file << "\n";
  }
  file.close();
  if (!file) return Status::Error("Cannot write " + path);
  return Status::Ok();
}

std::vector<std::string> CompareWithModelRecord(
    const colmap::Reconstruction& model, const std::string& path,
    const ModelRecordTolerances& tolerances) {
  Record record;
  if (!ReadRecord(path, &record)) {
    return {"cannot read the record " + path};
  }
  std::vector<std::string> differences;
  auto differ = [&differences](const std::string& what) {
    differences.push_back(what);
  };

  auto compare_count = [&](const char* what, size_t value, size_t recorded) {
    const double ratio =
        std::abs(static_cast<double>(value) - static_cast<double>(recorded)) /
        std::max<double>(1, recorded);
    if (ratio > tolerances.max_count_difference_ratio) {
      differ(std::string(what) + ": " + std::to_string(value) + ", recorded " +
             std::to_string(recorded));
    }
  };
  compare_count("points3D", model.NumPoints3D(), record.num_points3D);
  compare_count("observations", NumObservations(model),
                record.num_observations);

  for (const auto& [camera_id, params] : record.camera_params) {
    if (!model.ExistsCamera(camera_id)) {
      differ("camera " + std::to_string(camera_id) + " is missing");
      continue;
    }
    const std::vector<double>& now = model.Camera(camera_id).Params();
    bool same = now.size() == params.size();
    for (size_t k = 0; same && k < now.size(); ++k) {
      same = RelativeDifference(now[k], params[k]) <=
             tolerances.max_camera_param_difference;
    }
    if (!same) {
      std::ostringstream what;
      what << std::setprecision(10) << "camera " << camera_id << ": "
           << model.Camera(camera_id).ParamsToString() << ", recorded";
      for (const double param : params) what << " " << param;
      differ(what.str());
    }
  }

  // Centres are compared relative to the recorded scene's size.
  double scene_size = 0;
  std::vector<Eigen::Vector3d> recorded_centers;
  for (const auto& [name, image] : record.images) {
    recorded_centers.push_back(
        colmap::ProjectionCenterFromPose(image.qvec.normalized(), image.tvec));
  }
  for (size_t i = 0; i < recorded_centers.size(); ++i) {
    for (size_t j = i + 1; j < recorded_centers.size(); ++j) {
      scene_size = std::max(scene_size,
                            (recorded_centers[i] - recorded_centers[j]).norm());
    }
  }

  std::map<std::string, colmap::image_t> registered;
  for (const colmap::image_t image_id : model.RegImageIds()) {
    registered[model.Image(image_id).Name()] = image_id;
  }
  for (const auto& [name, image_id] : registered) {
    if (record.images.count(name) == 0) {
      differ("image " + name + " is registered, but not in the record");
    }
  }
  for (const auto& [name, recorded] : record.images) {
    const auto it = registered.find(name);
    if (it == registered.end()) {
      differ("image " + name + " is in the record, but not registered");
      continue;
    }
    const colmap::Image& image = model.Image(it->second);
    const Eigen::Vector3d center = image.ProjectionCenter();
    const Eigen::Vector3d recorded_center = colmap::ProjectionCenterFromPose(
        recorded.qvec.normalized(), recorded.tvec);
    const double center_ratio =
        (center - recorded_center).norm() / std::max(scene_size, 1e-12);
    const Eigen::Quaterniond q(image.Qvec()(0), image.Qvec()(1),
                               image.Qvec()(2), image.Qvec()(3));
    const Eigen::Quaterniond q_recorded(recorded.qvec(0), recorded.qvec(1),
                                        recorded.qvec(2), recorded.qvec(3));
    const double rotation_deg =
        q.normalized().angularDistance(q_recorded.normalized()) * 180 / M_PI;
    if (center_ratio > tolerances.max_center_difference_ratio ||
        rotation_deg > tolerances.max_rotation_difference_deg) {
      std::ostringstream what;
      what << "image " << name << ": centre " << center_ratio
           << " of the scene size and rotation " << rotation_deg
           << " deg from the record";
      differ(what.str());
    }
  }
  if (differences.size() > 20) {
    const size_t num_more = differences.size() - 20;
    differences.resize(20);
    differences.push_back("... and " + std::to_string(num_more) + " more");
  }
  return differences;
}

}  // namespace testing
}  // namespace glomap
