// VICAR and PDS4 products read through GDAL (its VICAR and PDS4 drivers), rather than by hand-written
// parsers: the camera model from the label and the pixels.
//
// VICAR: the label as GDAL gives it in the metadata domain `json:VICAR`; the model is the property
// GEOMETRIC_CAMERA_MODEL (MODEL_TYPE, MODEL_COMPONENT_ID, MODEL_COMPONENT_1..9 with the CAHVORE type and
// parameter as 8 and 9, REFERENCE_COORD_SYSTEM_NAME), the rover's pose the property ROVER_COORDINATE_SYSTEM,
// the exposure the property IDENTIFICATION; they are read by the PDS3 reader (Pds3Camera.cpp) from the same
// keywords. A file with a PDS3 label and an embedded VICAR label (MER, MSL) is opened as VICAR with
// GDAL_TRY_PDS3_WITH_VICAR=YES.
// PDS4: the XML label as GDAL gives it in `xml:PDS4` (parsed with GDAL's CPLParseXMLString); the model is
// geom:CAHVORE_Model, geom:CAHVOR_Model or geom:CAHV_Model under geom:Camera_Model_Parameters, each vector an
// element with three numeric children in x, y, z order (geom:Vector_Center, Vector_Axis, Vector_Horizontal,
// Vector_Vertical, Vector_Optical; geom:Radial_Terms and Entrance_Terms c0 c1 c2), the CAHVORE type and
// parameter geom:cahvore_model_type and geom:cahvore_model_parameter; the frame the first
// geom:coordinate_space_frame_type (or geom:reference_coord_system_name) that the model's parameters name.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "ground/io/CameraFile.hpp"

namespace areomap::io {

// True for a file that GDAL should read: it starts with a VICAR label ("LBLSIZE=") or is a PDS4 XML label.
bool isGdalLabelFile(const std::string& path);

// The camera file of a VICAR product (also one with a PDS3 label in front) or a PDS4 label, with the image
// size from the raster. Throws cli::InputError naming the file and the field.
CameraFile readVicarCamera(const std::string& path, int width = 0, int height = 0);
CameraFile readPds4Camera(const std::string& path, int width = 0, int height = 0);

// The pixels of a VICAR or PDS4 product (first band) as 8-bit grey: 8-bit data as they are, wider data by
// toGrey8's rule (ImageFile.hpp: 255 / (2^k - 1), 12-bit data in 16-bit words -> 4095).
cv::Mat readGdalImage8(const std::string& path);

}  // namespace areomap::io
