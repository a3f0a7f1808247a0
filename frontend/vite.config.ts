/// <reference types="vitest/config" />
import { fileURLToPath, URL } from 'node:url';
import react from '@vitejs/plugin-react';
import tailwindcss from '@tailwindcss/vite';
import { defineConfig } from 'vite';

// The build goes straight into the brain's static directory: it serves it at `/`.
const brainStatic = fileURLToPath(
  new URL('../packages/robot_voice_chat/src/robot_voice_chat/static', import.meta.url),
);
const brain = process.env.RVC_BRAIN_URL ?? 'http://127.0.0.1:8000';

export default defineConfig({
  plugins: [react(), tailwindcss()],
  resolve: { alias: { '@': fileURLToPath(new URL('./src', import.meta.url)) } },
  build: { outDir: brainStatic, emptyOutDir: true, sourcemap: false },
  server: {
    proxy: {
      '/api': brain,
      '/socket.io': { target: brain, ws: true },
    },
  },
  test: {
    environment: 'jsdom',
    setupFiles: ['./src/testing/setup.ts'],
    css: false,
  },
});
