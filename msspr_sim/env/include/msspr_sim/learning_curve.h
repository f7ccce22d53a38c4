// A training run's learning curve as a PNG (OpenCV), from the CSVs that
// msspr_train writes into its output directory.
#ifndef MSSPR_SIM_LEARNING_CURVE_H_
#define MSSPR_SIM_LEARNING_CURVE_H_

#include <string>

namespace msspr::sim {

// Reads eval_csv (rows "step,name,value": success_task<i>, mean_success and
// mean_success_custom are drawn, other names ignored) and metrics_csv (a header with "step" and
// loss columns; "critic" and "repr" are drawn) and writes png_path: success
// per task and the mean (%) against step on top, the two losses (log scale)
// below. A missing or empty CSV leaves its panel empty. Returns false, writing
// nothing, when neither file has a row. Throws std::runtime_error naming the
// file on a malformed row or when the PNG cannot be written.
bool SaveLearningCurvePlot(const std::string& eval_csv, const std::string& metrics_csv,
                           const std::string& png_path);

}  // namespace msspr::sim

#endif  // MSSPR_SIM_LEARNING_CURVE_H_
