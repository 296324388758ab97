"""What comes in and goes out as files: recordings, parameter tables, problem files, datasheets, segmentation."""
