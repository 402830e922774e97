pub mod off;
