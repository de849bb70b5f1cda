#pragma once
/// \file meshmark.h
/// The one header of meshmark's public API: include it to read and write meshes, make keys,
/// issue marked copies into a registry, read marks blind, trace leaks with the original and the
/// registry, attack and measure meshes. The headers below are the API; the others in this
/// folder (solvers, geometry helpers, the campaign machinery) are building blocks that may
/// change. examples/shop.cpp is a program built on this header alone.

#include "meshmark/attack.h"           // attacks and chains of attacks
#include "meshmark/calibrate.h"        // the strongest mark within fidelity limits
#include "meshmark/coding.h"           // coded buyer IDs
#include "meshmark/decode.h"           // the blind reading of a histogram mark
#include "meshmark/detect.h"           // is this ID there? with a false-alarm probability
#include "meshmark/embed.h"            // one embedding, its options and result
#include "meshmark/error.h"            // the exceptions every call throws
#include "meshmark/evidence_report.h"  // the HTML evidence report
#include "meshmark/report_pdf.h"       // ... and its PDF, printed by headless Chromium
#include "meshmark/io.h"               // reading and writing every mesh format
#include "meshmark/issue.h"            // issuing marked copies, recorded in a registry
#include "meshmark/key.h"              // secret keys and key files
#include "meshmark/mesh.h"             // the triangle mesh
#include "meshmark/metrics.h"          // distortion metrics (RMS, Hausdorff, MSDM, MSDM2)
#include "meshmark/payload.h"          // raw payloads
#include "meshmark/registry.h"         // the registry of issued copies
#include "meshmark/trace.h"            // naming the buyer of a leak
#include "meshmark/trace_files.h"      // tracing from files, with the report
#include "meshmark/variant.h"          // the framework's variants (DRS, VRS, ...)
#include "meshmark/version.h"          // meshmark's version
#include "meshmark/watermark.h"        // the protocol: keyed payloads and IDs, read back
