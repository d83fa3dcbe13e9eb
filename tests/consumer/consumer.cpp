// Uses the installed headers end to end: solve a frame of the paper's glove and map it to the grid.
#include <glovepose/glovepose.hpp>

#include <cstdio>
#include <memory>

int main() {
  using namespace glovepose;
  const auto layout = sensor::TraceLayout::glauser2019();
  auto solver = std::make_shared<const sensor::CapacitanceSolver>(layout);
  sensor::CapacitanceSolver::Capacitances truth = sensor::CapacitanceSolver::Capacitances::LinSpaced(44, 1.0, 2.0);
  const sensor::CapacitanceSolver::Measurements measured = solver->measurement_matrix() * truth;
  sensor::Readout readout(solver);
  if (readout.push_frame(measured, 0.0) != Status::Solved) return 1;
  if ((readout.frame().cells - truth).cwiseAbs().maxCoeff() > 1e-9) return 2;
  std::printf("glovepose %s: solved %d cells, cond(M) = %.2f\n", kVersion, layout.cell_count(), solver->condition_number());
  return 0;
}
