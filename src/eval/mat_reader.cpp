// MATLAB .mat ground-truth matrices through libmatio (v4, v5 plain or compressed, v7.3/HDF5).
#include <algorithm>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <matio.h>

#include "landmark_loop_closure/eval/ground_truth.h"

namespace landmark_loop_closure {
namespace eval {

namespace {

// libmatio reports through a process-wide log function; the last message of this thread becomes
// part of the error instead of a line on stderr.
thread_local std::string last_library_message;

void keepLibraryMessage(int /*log_level*/, char* message) {
  last_library_message = message ? message : "";
}

void routeLibraryMessages() {
  static std::once_flag once;
  std::call_once(once, [] { Mat_LogInitFunc("landmark_loop_closure", keepLibraryMessage); });
}

std::string libraryDetail() {
  return last_library_message.empty() ? std::string() : " (" + last_library_message + ")";
}

struct MatFileCloser {
  void operator()(mat_t* file) const { Mat_Close(file); }
};
struct VariableFreer {
  void operator()(matvar_t* variable) const { Mat_VarFree(variable); }
};
using MatFile = std::unique_ptr<mat_t, MatFileCloser>;
using Variable = std::unique_ptr<matvar_t, VariableFreer>;

bool isNumericClass(matio_classes type) {
  switch (type) {
    case MAT_C_DOUBLE:
    case MAT_C_SINGLE:
    case MAT_C_INT8:
    case MAT_C_UINT8:
    case MAT_C_INT16:
    case MAT_C_UINT16:
    case MAT_C_INT32:
    case MAT_C_UINT32:
    case MAT_C_INT64:
    case MAT_C_UINT64:
      return true;
    default:
      return false;
  }
}

bool isNonzero(const uint8_t* value, size_t size, bool floating) {
  if (floating && size == sizeof(double)) {
    double v;
    std::memcpy(&v, value, sizeof(v));
    return v != 0.0;
  }
  if (floating && size == sizeof(float)) {
    float v;
    std::memcpy(&v, value, sizeof(v));
    return v != 0.0f;
  }
  for (size_t i = 0; i < size; ++i) {
    if (value[i] != 0) return true;
  }
  return false;
}

bool isFloating(matio_types type) { return type == MAT_T_DOUBLE || type == MAT_T_SINGLE; }
bool isFloating(matio_classes type) { return type == MAT_C_DOUBLE || type == MAT_C_SINGLE; }

size_t sizeOfType(matio_types type) {
  switch (type) {
    case MAT_T_INT8:
    case MAT_T_UINT8:
    case MAT_T_UTF8:
      return 1;
    case MAT_T_INT16:
    case MAT_T_UINT16:
      return 2;
    case MAT_T_INT32:
    case MAT_T_UINT32:
    case MAT_T_SINGLE:
      return 4;
    case MAT_T_INT64:
    case MAT_T_UINT64:
    case MAT_T_DOUBLE:
      return 8;
    default:
      return 0;
  }
}

// libmatio inflates a compressed variable from its start for each block read, so blocks are as
// large as the budget allows (Bicocca's 26k x 26k: 25 s in blocks of 2 048 columns, 2 s in 8 800).
void readDense(mat_t* file, matvar_t* info, size_t block_bytes, GroundTruth* truth) {
  const size_t rows = info->dims[0];
  const size_t cols = info->dims[1];
  const size_t value_bytes = Mat_SizeOfClass(info->class_type);
  if (value_bytes == 0) throw GroundTruthError("unsupported value class");
  const size_t column_bytes = std::max<size_t>(1, rows * value_bytes);
  const size_t block_columns = std::max<size_t>(1, block_bytes / column_bytes);
  std::vector<uint8_t> block(std::min(block_columns, std::max<size_t>(cols, 1)) * column_bytes);
  const bool floating = isFloating(info->class_type);
  for (size_t first = 0; first < cols; first += block_columns) {
    const size_t count = std::min(block_columns, cols - first);
    int start[2] = {0, static_cast<int>(first)};
    int stride[2] = {1, 1};
    int edge[2] = {static_cast<int>(rows), static_cast<int>(count)};
    last_library_message.clear();
    if (Mat_VarReadData(file, info, block.data(), start, stride, edge) != 0) {
      throw GroundTruthError("'" + std::string(info->name) +
                             "' could not be read (truncated or corrupt?)" + libraryDetail());
    }
    // Column-major: value k of the block is (k % rows, first + k / rows).
    for (size_t k = 0; k < rows * count; ++k) {
      if (isNonzero(block.data() + k * value_bytes, value_bytes, floating)) {
        truth->add(k % rows, first + k / rows);
      }
    }
  }
}

void readSparse(mat_t* file, const std::string& name, size_t cols, GroundTruth* truth) {
  last_library_message.clear();
  const Variable full(Mat_VarRead(file, name.c_str()));
  if (!full || !full->data) {
    throw GroundTruthError("sparse '" + name + "' could not be read (truncated or corrupt?)" +
                           libraryDetail());
  }
  const auto* sparse = static_cast<const mat_sparse_t*>(full->data);
  const size_t value_bytes = sizeOfType(full->data_type);
  if (value_bytes == 0 || sparse->njc != cols + 1 || !sparse->jc || !sparse->ir) {
    throw GroundTruthError("sparse '" + name + "' is malformed");
  }
  // A logical matrix stores no false entries: every stored one is a positive. (libmatio takes a
  // logical matrix's values as bytes whatever the file stores them as, so they are not read.)
  const auto* values = full->isLogical ? nullptr : static_cast<const uint8_t*>(sparse->data);
  const bool floating = isFloating(full->data_type);
  for (size_t column = 0; column < cols; ++column) {
    const size_t begin = sparse->jc[column];
    const size_t end = sparse->jc[column + 1];
    if (begin > end || end > sparse->nir || (values && end > sparse->ndata)) {
      throw GroundTruthError("sparse '" + name + "' has a malformed column index");
    }
    for (size_t k = begin; k < end; ++k) {
      if (!values || isNonzero(values + k * value_bytes, value_bytes, floating)) {
        truth->add(sparse->ir[k], column);
      }
    }
  }
}

}  // namespace

GroundTruth readMatGroundTruth(const std::string& path, const std::string& variable,
                               size_t block_bytes) {
  try {
    routeLibraryMessages();
    last_library_message.clear();
    const MatFile file(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
    if (!file) {
      throw GroundTruthError("cannot open it as a MATLAB .mat file (v4, v5, v7 or v7.3)" +
                             libraryDetail());
    }
    std::vector<std::string> seen;
    while (true) {
      last_library_message.clear();
      const Variable info(Mat_VarReadNextInfo(file.get()));
      if (!info) break;
      const std::string name = info->name ? info->name : "";
      if (!name.empty()) seen.push_back(name);
      const bool sparse = info->class_type == MAT_C_SPARSE;
      if ((!sparse && !isNumericClass(info->class_type)) || info->rank != 2) continue;
      if (!variable.empty() && name != variable) continue;
      if (info->isComplex) throw GroundTruthError("'" + name + "' is complex");
      GroundTruth truth(info->dims[0], info->dims[1]);
      if (sparse) {
        readSparse(file.get(), name, info->dims[1], &truth);
      } else {
        readDense(file.get(), info.get(), block_bytes, &truth);
      }
      truth.finalize();
      return truth;
    }
    std::string listing;
    for (const std::string& name : seen) listing += (listing.empty() ? "" : ", ") + name;
    throw GroundTruthError(variable.empty()
                               ? "no 2-D numeric matrix in the file" + libraryDetail()
                               : "no 2-D numeric variable '" + variable + "' (found: " +
                                     (listing.empty() ? "none" : listing) + ")" + libraryDetail());
  } catch (const GroundTruthError& error) {
    throw GroundTruthError(path + ": " + error.what());
  }
}

}  // namespace eval
}  // namespace landmark_loop_closure
