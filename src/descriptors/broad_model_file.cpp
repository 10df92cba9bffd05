// The broad autoencoder's model file: magic, byte-order mark, version, options, weight matrices
// (each as rows, cols and column-major floats), CRC-32C of everything before it
// (checksummed_file.h).
#include <cmath>

#include "common/checksummed_file.h"
#include "landmark_loop_closure/descriptors/broad_autoencoder.h"

namespace landmark_loop_closure {

namespace {

constexpr char kBroadModelMagic[8] = {'L', 'L', 'C', 'B', 'R', 'O', 'A', 'D'};
constexpr uint32_t kBroadModelVersion = 1;
constexpr uint64_t kMaxValues = uint64_t{1} << 30;  // 4 GB of floats: anything more is damage.

void writeMatrix(LittleEndianWriter* writer, const Eigen::MatrixXf& matrix) {
  writer->u32(static_cast<uint32_t>(matrix.rows()));
  writer->u32(static_cast<uint32_t>(matrix.cols()));
  writer->floats(matrix.data(), static_cast<size_t>(matrix.size()));
}

bool readMatrix(LittleEndianReader* reader, Eigen::MatrixXf* matrix) {
  uint32_t rows = 0, cols = 0;
  if (!reader->u32(&rows) || !reader->u32(&cols)) return false;
  if (uint64_t{rows} * cols > kMaxValues || uint64_t{rows} * cols * 4 > reader->remaining()) {
    return false;
  }
  matrix->resize(rows, cols);
  return reader->floats(matrix->data(), static_cast<size_t>(matrix->size()));
}

bool readRow(LittleEndianReader* reader, Eigen::RowVectorXf* row) {
  Eigen::MatrixXf matrix;
  if (!readMatrix(reader, &matrix) || matrix.rows() != 1) return false;
  *row = matrix;
  return true;
}

}  // namespace

void BroadModel::save(const std::string& path) const {
  LittleEndianWriter writer;
  beginChecksummedFile(&writer, kBroadModelMagic, kBroadModelVersion);
  const BroadOptions& o = options;
  for (const int value : {o.input_width, o.input_height, o.mapped_groups, o.nodes_per_group,
                          o.enhancement_nodes, o.lasso_iterations}) {
    writer.u32(static_cast<uint32_t>(value));
  }
  writer.f64(o.output_fraction);
  writer.f64(o.lasso_lambda);
  writer.f64(o.ridge_lambda);
  writer.u32(o.seed);
  writeMatrix(&writer, mapping);
  writeMatrix(&writer, mapped_min);
  writeMatrix(&writer, mapped_range);
  writeMatrix(&writer, enhancement);
  writer.f32(enhancement_scale);
  writeMatrix(&writer, output);
  writer.f32(output_scale);
  writeMatrix(&writer, output_mean);
  writeMatrix(&writer, reconstruction);
  const std::string error = finishChecksummedFile(path, &writer);
  if (!error.empty()) throw BroadModelFileError("broad autoencoder model " + path + ": " + error);
}

BroadModel BroadModel::load(const std::string& path) {
  const auto fail = [&path](const std::string& what) {
    return BroadModelFileError("broad autoencoder model " + path + ": " + what);
  };
  std::vector<uint8_t> body;
  const std::string error = readChecksummedFile(path, kBroadModelMagic, kBroadModelVersion,
                                                "broad autoencoder model", &body);
  if (!error.empty()) throw fail(error);
  LittleEndianReader reader(body.data(), body.size());
  BroadModel model;
  BroadOptions& o = model.options;
  bool ok = true;
  for (int* value : {&o.input_width, &o.input_height, &o.mapped_groups, &o.nodes_per_group,
                     &o.enhancement_nodes, &o.lasso_iterations}) {
    uint32_t raw = 0;
    ok = ok && reader.u32(&raw) && raw < (1u << 30);
    *value = static_cast<int>(raw);
  }
  ok = ok && reader.f64(&o.output_fraction) && reader.f64(&o.lasso_lambda) &&
       reader.f64(&o.ridge_lambda) && reader.u32(&o.seed);
  if (!ok || !o.validate().empty()) throw fail("options are damaged");
  ok = readMatrix(&reader, &model.mapping) && readRow(&reader, &model.mapped_min) &&
       readRow(&reader, &model.mapped_range) && readMatrix(&reader, &model.enhancement) &&
       reader.f32(&model.enhancement_scale) && readMatrix(&reader, &model.output) &&
       reader.f32(&model.output_scale) && readRow(&reader, &model.output_mean) &&
       readMatrix(&reader, &model.reconstruction) && reader.remaining() == 0;
  if (!ok) throw fail("size does not match its contents");
  const Eigen::Index d = model.inputDimension();
  const Eigen::Index m = o.mappedNodes();
  const Eigen::Index e = o.enhancement_nodes;
  const Eigen::Index l = model.output.cols();
  const bool shapes = model.mapping.rows() == d + 1 && model.mapping.cols() == m &&
                      model.mapped_min.size() == m && model.mapped_range.size() == m &&
                      model.enhancement.rows() == m + 1 && model.enhancement.cols() == e &&
                      model.output.rows() == m + e + 1 && l > 0 && model.output_mean.size() == l &&
                      model.reconstruction.rows() == l && model.reconstruction.cols() == d;
  if (!shapes) throw fail("matrix shapes do not fit its options");
  const bool finite = model.mapping.allFinite() && model.mapped_min.allFinite() &&
                      model.mapped_range.allFinite() && (model.mapped_range.array() > 0).all() &&
                      model.enhancement.allFinite() && std::isfinite(model.enhancement_scale) &&
                      model.output.allFinite() && std::isfinite(model.output_scale) &&
                      model.output_mean.allFinite() && model.reconstruction.allFinite();
  if (!finite) throw fail("holds NaN or infinity");
  return model;
}

}  // namespace landmark_loop_closure
