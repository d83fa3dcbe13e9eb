/// @file replay.hpp
/// @brief Re-solving a recording's cells from its raw rows with another readout (e.g. another mean
/// window): what an estimator with those settings would have solved from the same readings.
///
/// Rows are replayed as the glove delivered them, each at its time (io::RowClock), one readout
/// per run (subject, glove, session: the calibration sequence and the session that continues it),
/// and the frame's cells are the readout's latest solve at the frame's end.
///
/// Set-up code: allocates, throws glovepose::Error naming what is wrong.
#pragma once

#include <memory>
#include <optional>

#include "../sensor/layout.hpp"
#include "../sensor/readout.hpp"
#include "../sensor/solver.hpp"
#include "../io/dataset.hpp"
#include "samples.hpp"

namespace glovepose::train {

/// @brief Replaces every frame's cells by the solve of its raw rows through a readout with
/// `config`. Throws glovepose::Error when the dataset has no raw rows or is not of the built-in
/// glove (whose wiring is known). A run's frames before its readout's first solve keep their cells.
inline void replay_rows(io::Dataset& data, const sensor::ReadoutConfig& config) {
  const sensor::TraceLayout layout = sensor::TraceLayout::glauser2019();
  if (data.glove_layout() != layout.id() || !data.has_raw_rows() || data.row_count != static_cast<std::size_t>(layout.row_count()))
    throw Error("replay: the dataset has " + std::to_string(data.row_count) + " raw rows per frame of glove '" + data.glove_layout() +
                "', expected the " + std::to_string(layout.row_count()) + " rows of '" + layout.id() + "' (glovepose simulate --raw-rows)");
  const auto solver = std::make_shared<const sensor::CapacitanceSolver>(layout);
  const io::RowClock clock = data.row_clock();
  std::optional<sensor::Readout> readout;
  std::int64_t current = -1;
  bool solved = false;
  for (std::size_t f = 0; f < data.frames(); ++f) {
    const std::int64_t key = run_key(data, f);
    if (key != current) readout.emplace(solver, config), current = key, solved = false;
    for (std::size_t r = 0; r < data.row_count; ++r) {
      const double t = clock.time(data.timestamps[f], r);
      if (readout->push_row(static_cast<int>(r), data.raw_rows[f * data.row_count + r], t) == Status::Solved) solved = true;
    }
    if (!solved) continue;  // a run's first cycle, before the first solve: the recorded cells stay
    for (std::size_t c = 0; c < data.cell_count; ++c)
      data.cells[f * data.cell_count + c] = static_cast<float>(readout->frame().cells(static_cast<Eigen::Index>(c)));
  }
  data.metadata["mean_window"] = std::to_string(config.mean_window);
}

}  // namespace glovepose::train
