#pragma once
/// \file meshmark.h
/// The one header of meshmark's public API: include it to read and write meshes, make keys,
/// issue marked copies into a registry, read marks blind, trace leaks with the original and the
/// registry, attack and measure meshes. The headers below are the API; the others in this
/// folder (solvers, geometry helpers, the campaign machinery) are building blocks that may
/// change. examples/shop.cpp is a program built on this header alone.

#include "meshmark/attacks/attack.h"             // attacks and chains of attacks
#include "meshmark/carrier/variant.h"            // the framework's variants (DRS, VRS, ...)
#include "meshmark/core/components.h"            // the optional components linked
#include "meshmark/core/error.h"                 // the exceptions every call throws
#include "meshmark/core/mesh.h"                  // the triangle mesh
#include "meshmark/forensics/evidence_report.h"  // the HTML evidence report
#include "meshmark/forensics/issue.h"            // issuing marked copies, recorded in a registry
#include "meshmark/forensics/registry.h"         // the registry of issued copies
#include "meshmark/forensics/report_pdf.h"       // ... and its PDF, printed by headless Chromium
#include "meshmark/forensics/spacing.h"          // issued codewords kept apart; IDs chosen
#include "meshmark/forensics/trace.h"            // naming the buyer of a leak
#include "meshmark/forensics/trace_files.h"      // tracing from files, with the report
#include "meshmark/io/io.h"                      // reading and writing every mesh format
#include "meshmark/mark/calibrate.h"             // the strongest mark within fidelity limits
#include "meshmark/mark/decode.h"                // the blind reading of a histogram mark
#include "meshmark/mark/embed.h"                 // one embedding, its options and result
#include "meshmark/mark/payload.h"               // raw payloads
#include "meshmark/metrics/metrics.h"            // distortion metrics (RMS, Hausdorff, MSDM, MSDM2)
#include "meshmark/protocol/coding.h"            // coded buyer IDs
#include "meshmark/protocol/detect.h"            // is this ID there? with a false-alarm probability
#include "meshmark/protocol/key.h"               // secret keys and key files
#include "meshmark/protocol/watermark.h"         // the protocol: keyed payloads and IDs, read back
#include "meshmark/version.h"                    // meshmark's version
