#!/usr/bin/env bash
# Installs what the peer benchmark (bench/peers/run.sh) needs, skipping what is already present:
#   Debian: python3-torch, python3-numpy (the reference model, ONNX export, PyTorch timing; always run
#           with /usr/bin/python3), libopenblas0-pthread (Debian's torch is built against the generic
#           libblas.so.3; without OpenBLAS that is netlib's reference BLAS and PyTorch's transposed
#           convolutions run several times slower than PyTorch normally does), nodejs + npm if missing.
#   npm:    onnxruntime-node (version pinned in package.json / package-lock.json) into
#           bench/peers/node_modules, with --ignore-scripts: its CPU binary ships inside the package,
#           the postinstall script would only fetch optional GPU binaries.
# torch.onnx.export of PyTorch 1.13 needs no `onnx` Python module, so python3-onnx is not installed.
# Nothing is downloaded at run time.
set -euo pipefail
cd "$(dirname "$0")"
extra=(libopenblas0-pthread)
command -v node >/dev/null || extra+=(nodejs)
command -v npm >/dev/null || extra+=(npm)
bash ../../tools/setup.sh "${extra[@]}"  # the build's packages (python3-torch, numpy among them) plus these
want=$(node -p "require('./package.json').dependencies['onnxruntime-node']")
have=$(node -p "try { require('./node_modules/onnxruntime-node/package.json').version } catch (e) { '' }")
if [ "$have" != "$want" ]; then
  echo "peers/setup: npm ci --ignore-scripts (onnxruntime-node $want)"
  npm ci --ignore-scripts --no-audit --no-fund
fi
node -e "require('onnxruntime-node')" || { echo "peers/setup: onnxruntime-node does not load" >&2; exit 1; }
/usr/bin/python3 -c "import torch, numpy" || { echo "peers/setup: /usr/bin/python3 cannot import torch/numpy" >&2; exit 1; }
echo "peers/setup: ready (onnxruntime-node $want, torch $(/usr/bin/python3 -c 'import torch; print(torch.__version__)'))"
