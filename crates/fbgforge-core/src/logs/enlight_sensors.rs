//! ENLIGHT "Sensors" export: after a metadata block, the header
//! `Timestamp<TAB><sensor name><TAB>…`; each row holds a timestamp and one wavelength per
//! sensor column (empty: no peak).

use super::detect::{Detected, HeadLine};
use super::enlight::{is_channel_column, is_timestamp_header, write_metadata, write_timestamp};
use super::rows::ValueColumns;
use super::write::write_number;
use super::{LogReader, LogStyle, LogTable, Rows};
use anyhow::Result;
use std::io::Write;
use std::path::Path;

/// The ENLIGHT Sensors format.
pub(crate) struct EnlightSensors;

impl LogReader for EnlightSensors {
    fn name(&self) -> &'static str {
        "enlight-sensors"
    }

    fn title(&self) -> &'static str {
        "ENLIGHT Sensors"
    }

    fn expected(&self) -> &'static str {
        "a line `Timestamp<TAB>sensor name<TAB>…`"
    }

    fn header_delimiter(&self, head: &HeadLine) -> Option<u8> {
        (is_timestamp_header(head) && !is_channel_column(head.second)).then_some(b'\t')
    }

    fn rows(
        &self,
        det: &Detected,
        _bytes: &[u8],
        _path: &Path,
        _opts: &super::ReadOptions,
    ) -> Result<Rows> {
        let names: Vec<String> = det.header[1..]
            .iter()
            .filter(|h| !h.is_empty())
            .cloned()
            .collect();
        Ok(Rows {
            channels: names.len(),
            parser: Box::new(ValueColumns {
                delimiter: det.delimiter,
                decimal_comma: det.decimal_comma(),
                columns: names.len(),
                std_error_of: Vec::new(),
            }),
            column_names: names,
            estimator: None,
        })
    }

    fn write(&self, w: &mut dyn Write, table: &LogTable, style: &LogStyle) -> std::io::Result<()> {
        let t0 = table.start_epoch_s;
        write_metadata(w, style.metadata_lines, table.sample_rate_hz, t0)?;
        writeln!(w, "Timestamp\t{}", table.names.join("\t"))?;
        for (i, row) in table.wavelength_nm.iter().enumerate() {
            write_timestamp(w, t0 + table.time_s[i], style)?;
            for v in row {
                w.write_all(b"\t")?;
                if v.is_finite() {
                    write_number(w, *v, 6, style.decimal_comma)?;
                }
            }
            writeln!(w)?;
        }
        Ok(())
    }
}
