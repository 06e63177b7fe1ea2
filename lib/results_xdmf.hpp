// The XDMF files beside a results file, for ParaView and meshio: the body (<stem>.xdmf: u,
// pressure, sigma33, E, P, sigma) and, with a contact surface, the contact surface
// (<stem>_contact.xdmf: beta, contact_pressure, gap, e, lambda_c per contact point). Which fields
// they show, and where, comes from the field table (lib/results_fields.hpp: the rows with an
// XDMF padding). They refer to the HDF5 file by its bare name, so keep the files side by side.
// Several steps: a temporal collection of uniform grids; one step: its uniform grid alone (what
// meshio.read() accepts).
#pragma once

#include <cstdint>
#include <string>

namespace ltl {

/// The XDMF file of the body beside a results file: path with .h5 replaced by suffix + ".xdmf"
/// (else path + suffix + ".xdmf").
std::string xdmf_path_of(const std::string& path, const std::string& suffix = "");
/// The XDMF file of the contact surface: <stem>_contact.xdmf.
std::string contact_xdmf_path_of(const std::string& path);
/// Whether `xdmf` is a regular file (not a link) that this code wrote for the results file
/// `path`: it opens with the comment naming path's file name (xdmf_text). The XDMF files beside a
/// results file are replaced only when they are (check_output_path).
bool is_xdmf_of(const std::string& xdmf, const std::string& path);
/// The XDMF text of the body (contact false) or of the contact surface of the open results file
/// `file_id` (an hid_t) written at `path` ("" when the file has no contact grid).
std::string xdmf_text(std::int64_t file_id, const std::string& path, bool contact);

}  // namespace ltl
