// The glovepose tool's commands other than predict/info, each in its own file.
#pragma once

namespace glovepose::cli {

/// `glovepose simulate ...` (simulate.cpp); argv[1] is "simulate". Returns the exit code.
int simulate(int argc, char** argv);

/// `glovepose train | finetune | eval ...` (train.cpp); argv[1] is the command. Returns the exit code.
int train_tools(int argc, char** argv);

}  // namespace glovepose::cli
